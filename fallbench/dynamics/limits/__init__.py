"""Limits of the whole-body QPs, one kind per file: contact (zero normal acceleration, as rows or as
a cost), joint ranges (acceleration bounds), torques."""
