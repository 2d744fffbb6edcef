"""Pre-impact strategies (fall detection to impact): the `Strategy` interface in `base.py`, one
strategy per module or package; registered by name in `fallbench.registry`."""
