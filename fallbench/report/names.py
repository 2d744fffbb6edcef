"""Names the report uses everywhere: arms (pre-impact strategy + gain policy) and the papers."""

from __future__ import annotations

NO_POLICY = "-"  # registry.NO_POLICY: a whole-fall controller (a learned policy) keeps its motors
PAPERS = {  # cited by authors and year at their first mention on a page
    "000": "000 (Samy & Kheddar 2015)",
    "002": "002 (Samy, Bouyarmane & Kheddar 2017)",
    "004": "004 (Nagarajan & Goswami 2010)",
}


def arm_name(strategy: str, policy: str) -> str:
    """ "none + adaptive_qp"; a whole-fall controller, which has no gain policy: "onnx (learned)"."""
    return f"{strategy} (learned)" if policy == NO_POLICY else f"{strategy} + {policy}"
