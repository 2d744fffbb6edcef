"""Pre-impact strategies: what the robot does between fall detection and impact.

`none` keeps the default gains and the starting pose until impact (the gain policies alone); `reshape`
runs the posture-reshaping and landing-point controller of 002 Sec. IV / 000 Sec. IV.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the reshaping controller loads only for runs that reshape (start-up time)
    from fallbench.control.reshape import ReshapeController
    from fallbench.scenario import Scenario
    from fallbench.world import World

STRATEGIES = ("none", "reshape")


def make_strategy(name: str, world: World, scenario: Scenario) -> ReshapeController | None:
    if name not in STRATEGIES:
        raise ValueError(f"unknown pre-impact strategy {name!r}; known: {', '.join(STRATEGIES)}")
    if name == "none":
        return None
    from fallbench.control.reshape import ReshapeController

    return ReshapeController(world, scenario, scenario.policy_params.get("reshape"))
