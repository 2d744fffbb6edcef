"""Damage and outcome measures of a recorded fall: one row of metrics per run."""
