"""Sizes that depend on the robot: a file's push forces and obstacle geometry, written for one
robot (`sizes_for`), carried to the robot a point runs on."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fallbench.robots import get_robot
from fallbench.yamlfile import InputError

SCALE_PREFIX = "scale:"  # swept entries recording the factors applied to a file's sizes


class StandingHeightNeeded(InputError):
    """A file's sizes are carried between robots, one of whose cards leaves `standing_height` out
    and which nothing has derived yet: `fallbench.checks.load` derives it (it settles the robot, a
    simulation this layer cannot run) and reads the files again."""

    def __init__(self, path: Path, line: int | None, robot: str) -> None:
        super().__init__(path, line, "sizes_for", get_robot(robot).unknown_height_reason())
        self.robot = robot  # as runs carry it: a shipped name or a card's path


def unknown_heights(*robots: str) -> list[str]:
    """The robots of `robots` whose standing height is neither given nor derived yet."""
    return [robot for robot in robots if not get_robot(robot).standing_height_known]


def robot_scales(robot: str, sizes_for: str) -> dict[str, float]:
    """Factors that carry a file's sizes from robot `sizes_for` to `robot`: forces by the mass
    ratio (the same change of CoM velocity, F t / m), lengths by the ratio of standing heights."""
    target, reference = get_robot(robot), get_robot(sizes_for)
    return {
        "force": target.mass / reference.mass,
        "length": target.standing_height / reference.standing_height,
    }


def scale_sizes(data: dict[str, Any], scales: dict[str, float]) -> None:
    """Push force and obstacle positions and dimensions (robot at the origin) of a point, in place."""
    push = data.get("push")
    if isinstance(push, dict) and isinstance(push.get("force"), (int, float)):
        push["force"] = push["force"] * scales["force"]
    for obstacle in data.get("obstacles") or []:
        if not isinstance(obstacle, dict):
            continue
        for key in ("pos", "size"):
            if isinstance(obstacle.get(key), list):
                obstacle[key] = [
                    v * scales["length"] if isinstance(v, (int, float)) else v for v in obstacle[key]
                ]
        for key in ("radius", "height"):
            if isinstance(obstacle.get(key), (int, float)):
                obstacle[key] = obstacle[key] * scales["length"]
