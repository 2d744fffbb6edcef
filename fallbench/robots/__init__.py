"""Robots: each is a card (a YAML file, fallbench/robots/card.py) and the URDF it points at.

The shipped robots are the cards in `fallbench/robots/cards/`, by file name; a scenario's `robot`
is one of those names or the path of a user's card (`robot: my_robot/card.yaml`).
"""

from __future__ import annotations

import functools
import hashlib
import os
from collections import Counter
from pathlib import Path

from fallbench.robots.card import load_card
from fallbench.robots.description import RobotDescription

CARDS = Path(__file__).parent / "cards"
ROBOTS: dict[str, Path] = {path.stem: path for path in sorted(CARDS.glob("*.yaml"))}  # shipped, by name
DEFAULT_ROBOT = "talos"  # what a scenario without a `robot` key runs on
CARD_SUFFIXES = (".yaml", ".yml")


def is_card_path(robot: str) -> bool:
    """Whether a scenario's `robot` names a card file rather than a shipped robot."""
    return robot.endswith(CARD_SUFFIXES)


def resolve_robot(robot: str, folder: Path) -> str:
    """A scenario's `robot` as runs carry it: a shipped name as is, a card's path made absolute
    from `folder` (the scenario file's)."""
    return os.path.abspath(folder / robot) if is_card_path(robot) else robot  # no file system call


def robot_problem(robot: str) -> str | None:
    """Why `robot` names no robot (an unknown name, a missing card file), else None."""
    if is_card_path(robot):
        return None if Path(robot).is_file() else f"no robot card at {robot}"
    if robot not in ROBOTS:
        return f"unknown robot {robot!r} (known: {', '.join(ROBOTS)}, or a card file *.yaml)"
    return None


@functools.cache  # (`cache` here would be the submodule fallbench.robots.cache once imported)
def get_robot(robot: str) -> RobotDescription:
    """The robot of a shipped name or a card path; KeyError for an unknown name, InputError
    (file:line: key: reason) for a bad card."""
    if robot in ROBOTS:
        return load_card(ROBOTS[robot])
    if is_card_path(robot):
        return load_card(Path(robot))
    raise KeyError(f"unknown robot {robot!r}; known: {', '.join(ROBOTS)}")


def robot_names(robots: list[str]) -> dict[str, str]:
    """What reports call each robot of `robots` (as runs carry them: shipped names, card paths):
    a shipped robot by its name, a card by its `name` (the card file's stem when the card no
    longer loads), so that figure files and page titles never hold a path. Two cards of the same
    `name`, or a card named as a shipped robot, are told apart by a hash of their path."""
    names = {robot: _card_name(robot) if is_card_path(robot) else robot for robot in robots}
    taken = Counter(names.values())
    for robot, name in names.items():
        if is_card_path(robot) and (taken[name] > 1 or name in ROBOTS):
            names[robot] = f"{name}-{hashlib.sha256(robot.encode()).hexdigest()[:6]}"
    return names


def _card_name(card: str) -> str:
    try:
        return get_robot(card).name
    except (OSError, ValueError):  # the card moved or no longer loads: its runs keep a name
        return Path(card).stem
