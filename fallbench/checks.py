"""The checks of a scenario that need more than its schema: the robot and the scene
(`sim.world.check_scene`) and the registered controllers (unknown names, `policy_params` entries of
the wrong type or value, a part of the robot a strategy needs, a strategy's own checks, the
baseline gain scale); and scenario files loaded with them (`load`).

Each check gives `(key, reason)` of the first problem, else None; `load` reports it as
`FILE:LINE: key: reason` (`ScenarioError`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from fallbench.registry import policies, strategies
from fallbench.robots import get_robot
from fallbench.robots.card import card_key
from fallbench.scenario import Scenario, ScenarioPoint, load_scenarios
from fallbench.scenario.sizes import StandingHeightNeeded
from fallbench.sim.baseline import GAIN_SCALE_KEY, GAIN_SCALE_SECTION, gain_scale
from fallbench.sim.settle import ensure_standing_height
from fallbench.sim.world import check_scene

Problem = tuple[str, str] | None


def load(paths: list[Path] | list[Path | str], robot: str | None = None) -> list[ScenarioPoint]:
    """Scenario files parsed, expanded and checked completely (raises `ScenarioError`). A file whose
    sizes are carried to a robot whose card leaves `standing_height` out is read again once the
    height is derived (`ensure_standing_height`)."""
    derived: set[str] = set()
    paths = list(paths)  # read again after a derivation
    while True:
        try:
            return load_scenarios(paths, robot, check=check_scenario)
        except StandingHeightNeeded as needed:
            if needed.robot in derived:
                raise
            ensure_standing_height(needed.robot)
            derived.add(needed.robot)


def check_scenario(scenario: Scenario) -> Problem:
    """The first problem of a parsed scenario that needs the robot, the scene or the registered
    controllers to see; a standing height the card leaves out is derived here (the metrics read it)."""
    problem = check_scene(scenario)
    if problem:
        return problem
    ensure_standing_height(scenario.robot)
    return check_controllers(scenario)


def check_controllers(scenario: Scenario) -> Problem:
    """The first unknown strategy, bad `policy_params` entry, strategy that cannot run on the
    scenario, or a baseline gain scale <= 0."""
    registered = strategies()
    for index, name in enumerate(scenario.pre_impact or ()):
        if name not in registered:
            return (
                f"pre_impact.{index}",
                f"unknown pre-impact strategy {name!r} (known: {', '.join(registered)})",
            )
    problem = check_parameters(scenario)
    if problem:
        return problem
    configured = [name for name in registered if name in scenario.policy_params]
    problem = check_strategies(scenario, [*(scenario.pre_impact or ()), *configured])
    if problem:
        return problem
    if gain_scale(scenario) <= 0:
        return (
            f"policy_params.{GAIN_SCALE_SECTION}.{GAIN_SCALE_KEY}",
            f"the baseline gain scale must be > 0 (got {gain_scale(scenario)})",
        )
    return None


def check_parameters(scenario: Scenario) -> Problem:
    """The first `policy_params` entry that names no registered policy or strategy, or no parameter
    of it, or whose value does not fit the parameter's default's type or its allowed values."""
    classes = {**policies(), **{name: cls for name, cls in strategies().items() if cls.defaults}}
    parameters = {name: cls.defaults for name, cls in classes.items()}
    for owner, params in scenario.policy_params.items():
        if owner not in parameters:
            return f"policy_params.{owner}", f"unknown policy or strategy (known: {', '.join(parameters)})"
        unknown = sorted(set(params) - set(parameters[owner]))
        if unknown:
            known = ", ".join(sorted(parameters[owner])) or "none"
            return f"policy_params.{owner}.{unknown[0]}", f"unknown parameter of {owner!r} (known: {known})"
        for key, value in params.items():
            problem = _parameter_problem(parameters[owner][key], value)
            allowed = (policies().get(owner) or strategies()[owner]).choices.get(key)
            if not problem and allowed and value not in allowed:
                problem = f"expected one of {', '.join(allowed)} (got {value!r})"
            if problem:
                return f"policy_params.{owner}.{key}", problem
    return None


def check_strategies(scenario: Scenario, names: list[str] | tuple[str, ...]) -> Problem:
    """The first problem of these strategies on `scenario`: a part of the robot one needs that its
    card leaves out, or the strategy's own checks (a model file)."""
    for name in names:
        strategy = strategies().get(name)
        if strategy is None:
            continue
        robot = get_robot(scenario.robot)
        missing = robot.missing(strategy.robot_needs)
        if missing:
            return "robot", (
                f"strategy {name!r} needs the robot's `{card_key(missing)}`, which {robot.card_path} "
                "does not give"
            )
        problem = strategy.check(scenario)
        if problem:
            return problem
    return None


def _parameter_problem(default: Any, value: Any) -> str | None:
    """Why a policy or strategy parameter's value does not fit its default's type, else None."""
    if isinstance(default, bool) or isinstance(default, str):
        return (
            None if isinstance(value, type(default)) else f"expected {type(default).__name__} (got {value!r})"
        )
    if isinstance(default, (int, float)):
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        return None if number and math.isfinite(value) else f"expected a finite number (got {value!r})"
    return None
