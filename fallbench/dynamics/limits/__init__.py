"""Limits of the whole-body QPs, each a `Limit` (limit.py) giving `LimitRows`, one kind per file:
contact (zero normal acceleration; the contact-motion costs beside it), joint ranges (acceleration
bounds), motor torques."""
