"""Pre-impact strategies, by the name users type in `--pre-impact`: the built-in ones and those
other packages register under the `fallbench.strategies` entry point (see `fallbench.plugins`)."""

from __future__ import annotations

from typing import Any

from fallbench.plugins import Registry
from fallbench.preimpact.base import Strategy
from fallbench.preimpact.direction.strategy import DirectionStrategy
from fallbench.preimpact.none import NoStrategy
from fallbench.preimpact.reshape import ReshapeStrategy

STRATEGIES: dict[str, type[Strategy]] = Registry("fallbench.strategies", Strategy, {
    "none": NoStrategy, "reshape": ReshapeStrategy, "direction": DirectionStrategy}, "pre-impact strategy")


def make_strategy(name: str, world: Any, scenario: Any) -> Strategy:
    return STRATEGIES.create(name, world, scenario)  # type: ignore[attr-defined]


__all__ = ["STRATEGIES", "Strategy", "make_strategy"]
