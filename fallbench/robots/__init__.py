"""Robot registry: a new robot is a new entry here, not a fork of the simulator code."""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

from fallbench.robots.description import RobotDescription
from fallbench.robots.g1 import g1
from fallbench.robots.talos import talos

ROBOTS: dict[str, Callable[[], RobotDescription]] = {"talos": talos, "g1": g1}
DEFAULT_ROBOT = "talos"  # what a scenario without a `robot` key runs on


@cache
def get_robot(name: str) -> RobotDescription:
    try:
        factory = ROBOTS[name]
    except KeyError:
        raise KeyError(f"unknown robot {name!r}; known: {', '.join(sorted(ROBOTS))}") from None
    return factory()
