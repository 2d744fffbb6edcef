"""The plug-in registry: every pre-impact strategy and post-impact gain policy by the name users
type, the checks of a scenario's controller parameters, and the one place where a run's world and
controllers are put together for the episode loop.

A new built-in is a new file plus a line in `POLICIES` or `STRATEGIES` (robots: `fallbench.robots`).
Other installed packages add their own through Python entry points: a package declares, in its pyproject.toml,

    [project.entry-points."fallbench.strategies"]
    my_strategy = "my_package.module:MyStrategy"

(or `fallbench.policies` for a gain policy); the name users type is the entry point's name.
Entry points are loaded on the registry's first use, not at import, so that a plug-in may import
fallbench's own modules (its base classes) without a circular import.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from fallbench.postimpact.adaptive_qp.policy import AdaptiveQPPolicy
from fallbench.postimpact.adaptive_qp_hold import AdaptiveQPHoldPolicy
from fallbench.postimpact.base import GainPolicy
from fallbench.postimpact.oneshot import OneshotPolicy
from fallbench.postimpact.stiff import StiffPolicy
from fallbench.postimpact.zero import ZeroPolicy
from fallbench.preimpact.base import Strategy
from fallbench.preimpact.direction.strategy import DirectionStrategy
from fallbench.preimpact.learned.onnx import OnnxStrategy
from fallbench.preimpact.none import NoStrategy
from fallbench.preimpact.reshape.strategy import ReshapeStrategy
from fallbench.robots import get_robot
from fallbench.robots.card import card_key
from fallbench.scenario import Scenario, ScenarioPoint, load_scenarios
from fallbench.sim.baseline import gain_scale, with_gain_scale
from fallbench.sim.episode import run_episode
from fallbench.sim.recorder import Recording
from fallbench.sim.world import World, build_world, check_scene


class Registry(dict):
    """name -> class: the built-in ones, then the entry points of `group` on first use."""

    def __init__(self, group: str, base: type, builtin: dict[str, Any], kind: str) -> None:
        super().__init__(builtin)
        self.group, self.base, self.kind, self.loaded = group, base, kind, False

    def create(self, name: str, *args: Any) -> Any:
        """An instance of the class registered as `name`."""
        if name not in self:
            raise ValueError(f"unknown {self.kind} {name!r}; known: {', '.join(self)}")
        return self[name](*args)

    def _load(self) -> None:
        if self.loaded:
            return
        self.loaded = True
        for entry in entry_points(group=self.group):
            if dict.__contains__(self, entry.name):
                raise ValueError(
                    f"entry point {entry.name!r} = {entry.value!r} ({self.group}) clashes with a built-in name"
                )
            cls = entry.load()
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise TypeError(
                    f"entry point {entry.name!r} = {entry.value!r} ({self.group}) is not a {self.base.__name__} subclass"
                )
            dict.__setitem__(self, entry.name, cls)

    def __getitem__(self, name: str) -> Any:
        self._load()
        return dict.__getitem__(self, name)

    def __contains__(self, name: object) -> bool:
        self._load()
        return dict.__contains__(self, name)

    def __iter__(self) -> Iterator[str]:
        self._load()
        return dict.__iter__(self)

    def __len__(self) -> int:
        self._load()
        return dict.__len__(self)

    def get(self, name: str, default: Any = None) -> Any:
        self._load()
        return dict.get(self, name, default)

    def keys(self):  # type: ignore[override]
        self._load()
        return dict.keys(self)

    def values(self):  # type: ignore[override]
        self._load()
        return dict.values(self)

    def items(self):  # type: ignore[override]
        self._load()
        return dict.items(self)


POLICIES: dict[str, type[GainPolicy]] = Registry(
    "fallbench.policies",
    GainPolicy,
    {
        "stiff": StiffPolicy,
        "oneshot": OneshotPolicy,
        "zero": ZeroPolicy,
        "adaptive_qp": AdaptiveQPPolicy,
        "adaptive_qp_hold": AdaptiveQPHoldPolicy,
    },
    "policy",
)

STRATEGIES: dict[str, type[Strategy]] = Registry(
    "fallbench.strategies",
    Strategy,
    {
        "none": NoStrategy,
        "reshape": ReshapeStrategy,
        "direction": DirectionStrategy,
        "onnx": OnnxStrategy,
    },
    "pre-impact strategy",
)

NO_POLICY = "-"  # the policy of a whole-fall controller's runs: it never hands its motors over


def stat_columns() -> dict[str, Any]:
    """The columns every run's row has, whichever controllers ran: each registered policy's and
    strategy's `stat_columns`, in registration order, with the value of the runs it did not take
    part in. Two that declare one column must agree on its value."""
    columns: dict[str, Any] = {}
    owner: dict[str, str] = {}
    for name, cls in [*POLICIES.items(), *STRATEGIES.items()]:
        for column, default in cls.stat_columns.items():
            if column in columns and not _same(columns[column], default):
                raise ValueError(
                    f"{name!r} declares the stat column {column!r} = {default!r}, "
                    f"{owner[column]!r} = {columns[column]!r}"
                )
            columns.setdefault(column, default)
            owner.setdefault(column, name)
    return columns


def _same(a: Any, b: Any) -> bool:
    """Equal values, NaN equal to NaN."""
    return bool(a == b) or (a != a and b != b)


def run_policy(pre_impact: str, policy: str) -> str:
    """The gain policy a run of `pre_impact` carries: `policy`, or `-` for a whole-fall controller."""
    strategy = STRATEGIES.get(pre_impact)
    return NO_POLICY if strategy is not None and not strategy.hands_over else policy


def check_strategies(scenario: Scenario, names: list[str] | tuple[str, ...]) -> tuple[str, str] | None:
    """(key, reason) of the first problem of these strategies on `scenario`: a part of the robot
    one needs that its card leaves out, or the strategy's own checks (a model file); else None."""
    for name in names:
        strategy = STRATEGIES.get(name)
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


def check_controllers(scenario: Scenario) -> tuple[str, str] | None:
    """(key, reason) of the first unknown strategy or bad `policy_params` entry, else None."""
    for index, name in enumerate(scenario.pre_impact or ()):
        if name not in STRATEGIES:
            return (
                f"pre_impact.{index}",
                f"unknown pre-impact strategy {name!r} (known: {', '.join(STRATEGIES)})",
            )
    parameters = {name: policy.defaults for name, policy in POLICIES.items()} | {
        name: strategy.defaults for name, strategy in STRATEGIES.items() if strategy.defaults
    }
    for policy, params in scenario.policy_params.items():
        if policy not in parameters:
            return f"policy_params.{policy}", f"unknown policy or strategy (known: {', '.join(parameters)})"
        unknown = sorted(set(params) - set(parameters[policy]))
        if unknown:
            known = ", ".join(sorted(parameters[policy])) or "none"
            return f"policy_params.{policy}.{unknown[0]}", f"unknown parameter of {policy!r} (known: {known})"
        for key, value in params.items():
            problem = _parameter_problem(parameters[policy][key], value)
            allowed = getattr(POLICIES.get(policy) or STRATEGIES.get(policy), "choices", {}).get(key)
            if not problem and allowed and value not in allowed:
                problem = f"expected one of {', '.join(allowed)} (got {value!r})"
            if problem:
                return f"policy_params.{policy}.{key}", problem
    strategies = [name for name in STRATEGIES if name in scenario.policy_params]
    problem = check_strategies(scenario, [*(scenario.pre_impact or ()), *strategies])
    if problem:
        return problem
    if gain_scale(scenario) <= 0:
        return (
            "policy_params.stiff.gain_scale",
            f"the baseline gain scale must be > 0 (got {gain_scale(scenario)})",
        )
    return None


def check_scenario(scenario: Scenario) -> tuple[str, str] | None:
    """(key, reason) of the first problem of a parsed scenario that needs the robot, the scene or
    the registered controllers to see, else None."""
    return check_scene(scenario) or check_controllers(scenario)


def load(paths: list[Path] | list[Path | str], robot: str | None = None) -> list[ScenarioPoint]:
    """Scenario files parsed, expanded and checked completely (raises `ScenarioError`)."""
    return load_scenarios(paths, robot, check=check_scenario)


def run_world(scenario: Scenario) -> World:
    """The world a run simulates: the scenario's, with its default gains times
    `policy_params.stiff.gain_scale`, the baseline stiffness every policy uses before impact
    (and `stiff` after)."""
    return with_gain_scale(build_world(scenario), gain_scale(scenario))


def simulate_named(scenario: Scenario, policy: str, pre_impact: str = "none") -> Recording:
    """One fall under the registered gain policy and pre-impact strategy of these names."""
    if (policy == NO_POLICY) != (run_policy(pre_impact, policy) == NO_POLICY):
        raise ValueError(
            f"policy {policy!r} with strategy {pre_impact!r}: `-` goes with whole-fall strategies only"
        )
    world = run_world(scenario)
    # a whole-fall controller never hands over: its episode is given `stiff`, which never acts
    gain_policy = POLICIES.create(  # type: ignore[attr-defined]
        "stiff" if policy == NO_POLICY else policy, world, scenario
    )
    strategy = STRATEGIES.create(pre_impact, world, scenario)  # type: ignore[attr-defined]
    return run_episode(world, scenario, gain_policy, strategy, pre_impact, stat_columns())
