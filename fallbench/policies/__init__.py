"""Post-impact gain policies, by the name users type in `--policies`: the built-in ones and those
other packages register under the `fallbench.policies` entry point (see `fallbench.plugins`)."""

from __future__ import annotations

from typing import Any

from fallbench.plugins import Registry
from fallbench.policies.adaptive_qp import AdaptiveQPPolicy
from fallbench.policies.base import GainPolicy, Observation
from fallbench.policies.oneshot import OneshotPolicy
from fallbench.policies.stiff import StiffPolicy
from fallbench.policies.zero import ZeroPolicy

POLICIES: dict[str, type[GainPolicy]] = Registry("fallbench.policies", GainPolicy, {
    "stiff": StiffPolicy,
    "oneshot": OneshotPolicy,
    "zero": ZeroPolicy,
    "adaptive_qp": AdaptiveQPPolicy,
}, "policy")


def make_policy(name: str, world: Any, scenario: Any) -> GainPolicy:
    return POLICIES.create(name, world, scenario)  # type: ignore[attr-defined]


__all__ = ["GainPolicy", "Observation", "POLICIES", "make_policy"]
