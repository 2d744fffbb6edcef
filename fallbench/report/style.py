"""One colour and label per policy, everywhere."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # files only, no screen

POLICY_COLOURS = {"stiff": "#d62728", "oneshot": "#ff7f0e", "zero": "#7f7f7f", "adaptive_qp": "#1f77b4"}
POLICY_ORDER = list(POLICY_COLOURS)
STRATEGY_LINES = {"none": "--", "reshape": "-"}  # line style per pre-impact strategy


def colour(policy: str) -> str:
    return POLICY_COLOURS.get(policy, "#2ca02c")


def ordered(policies) -> list[str]:
    present = set(policies)
    return [p for p in POLICY_ORDER if p in present] + sorted(present - set(POLICY_ORDER))
