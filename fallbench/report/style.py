"""One colour and label per policy, everywhere."""

from __future__ import annotations

# Okabe-Ito colours: told apart with any colour vision (stiff vermillion, onnx bluish green)
POLICY_COLOURS = {"stiff": "#D55E00", "oneshot": "#E69F00", "zero": "#CC79A7", "adaptive_qp": "#0072B2"}
OTHER_COLOUR = "#009E73"
POLICY_ORDER = list(POLICY_COLOURS)
STRATEGY_LINES = {"none": "--", "reshape": "-"}  # line style per pre-impact strategy


def colour(policy: str) -> str:
    return POLICY_COLOURS.get(policy, OTHER_COLOUR)


def ordered(policies) -> list[str]:
    present = set(policies)
    return [p for p in POLICY_ORDER if p in present] + sorted(present - set(POLICY_ORDER))
