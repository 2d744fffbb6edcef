"""Sweep expansion: a scenario file's sweep values, randomised keys and seeds expanded into
`ScenarioPoint`s, each scaled to its robot and validated, a bad value located at the sweep (or
randomize) entry that produced it."""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError
from ruamel.yaml.comments import CommentedMap

from fallbench.robots import DEFAULT_ROBOT, resolve_robot, robot_problem
from fallbench.scenario.schema import UNION_TAGS, Scenario, ScenarioError, ScenarioFile
from fallbench.scenario.sizes import (
    SCALE_PREFIX,
    StandingHeightNeeded,
    robot_scales,
    scale_sizes,
    unknown_heights,
)
from fallbench.yamlfile import error_location, line_of, plain, validation_error


@dataclass(frozen=True)
class ScenarioPoint:
    """One point of a scenario file's sweep, with the values that made it."""

    scenario: Scenario
    swept: dict[str, Any]  # dotted key -> value, sweep and randomised keys
    source: str  # file the point came from
    randomized: frozenset[str] = frozenset()  # keys of `swept` drawn from the seed

    @property
    def label(self) -> str:
        """The run's point name: scenario, swept and drawn values, seed."""
        return self._name(set()) + f"#s{self.scenario.seed}"

    @property
    def group(self) -> str:
        """The point over its seeds: the label without the seed and the values drawn from it."""
        return self._name(self.randomized)

    def _name(self, leave_out: set[str] | frozenset[str]) -> str:
        parts = [
            f"{k}={_fmt(v)}"
            for k, v in self.swept.items()
            if not k.startswith(SCALE_PREFIX) and k not in leave_out
        ]
        if "robot" not in self.swept and self.scenario.robot != DEFAULT_ROBOT:
            parts.insert(0, f"robot={self.scenario.robot}")  # points of different robots never share a label
        return self.scenario.name + ("[" + ",".join(parts) + "]" if parts else "")


def _fmt(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def _set_dotted(data: dict[str, Any], dotted: str, value: Any) -> None:
    keys = dotted.split(".")
    node = data
    for key in keys[:-1]:
        if node.get(key) is None:
            node[key] = {}
        node = node[key]
        if not isinstance(node, dict):
            raise KeyError(dotted)
    node[keys[-1]] = value


def _turn_layout(data: dict[str, Any], yaw_deg: float) -> None:
    """Obstacles turned by `yaw_deg` about the origin: positions rotate, boxes turn with them."""
    if not yaw_deg or not isinstance(data.get("obstacles"), list):
        return
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    for obstacle in data["obstacles"]:
        if isinstance(obstacle, dict) and isinstance(obstacle.get("pos"), list) and len(obstacle["pos"]) == 3:
            x, y, z = obstacle["pos"]
            obstacle["pos"] = [c * x - s * y, s * x + c * y, z]
            if obstacle.get("type") == "box":
                obstacle["yaw"] = obstacle.get("yaw", 0.0) + yaw_deg


def expand_points(
    path: Path, doc: CommentedMap, spec: ScenarioFile, robot: str | None = None
) -> list[ScenarioPoint]:
    base = plain(doc)
    for key in ("sweep", "randomize", "seeds", "sizes_for", "per_robot"):
        base.pop(key, None)
    sweep = (
        {"robot": [robot], **{k: v for k, v in spec.sweep.items() if k != "robot"}} if robot else spec.sweep
    )
    sweep_keys = list(sweep)
    points = []
    for values in itertools.product(*(sweep[k] for k in sweep_keys)):
        for rep in range(spec.seeds):
            data = copy.deepcopy(base)
            seed = spec.seed + rep
            data["seed"] = seed
            swept: dict[str, Any] = dict(zip(sweep_keys, values))
            rng = np.random.default_rng(seed)
            for key, (low, high) in sorted(spec.randomize.items()):
                swept[key] = float(rng.uniform(low, high))
            for key, value in swept.items():
                try:
                    _set_dotted(data, key, value)
                except (KeyError, TypeError):
                    raise ScenarioError(
                        path, line_of(doc, key_origin(spec, key)), key, "not a key of the scenario"
                    ) from None
            yaw = data.pop("layout_yaw", 0.0)
            if isinstance(yaw, bool) or not isinstance(yaw, (int, float)) or not math.isfinite(yaw):
                raise ScenarioError(
                    path,
                    line_of(doc, key_origin(spec, "layout_yaw")),
                    "layout_yaw",
                    f"expected degrees (got {yaw!r})",
                )
            _turn_layout(data, yaw)
            if isinstance(data.get("robot"), str):
                data["robot"] = resolve_robot(data["robot"], path.parent)
            swept.update(_robot_sizes(path, doc, spec, data))
            try:
                scenario = Scenario.model_validate(data)
            except ValidationError as exc:
                raise _sweep_error(path, doc, spec, swept, exc) from None
            points.append(ScenarioPoint(scenario, swept, str(path), frozenset(spec.randomize)))
    return points


def _robot_sizes(path: Path, doc: CommentedMap, spec: ScenarioFile, data: dict[str, Any]) -> dict[str, float]:
    """Scale a point's sizes to its robot and apply the file's per-robot values, in place;
    returns the factors applied, as `scale:*` entries for the point's record. Robots are compared
    as runs carry them (card paths resolved from the file's folder)."""
    robot = data.get("robot", DEFAULT_ROBOT)
    if not isinstance(robot, str) or robot_problem(robot):
        return {}  # reported by the schema (a name) or by check_scenario (a robot), at the `robot` key
    applied: dict[str, float] = {}
    sizes_for = resolve_robot(spec.sizes_for, path.parent) if spec.sizes_for is not None else None
    if sizes_for is not None and robot != sizes_for:
        unknown = unknown_heights(robot, sizes_for)
        if unknown:  # a card without `standing_height`, not derived yet
            raise StandingHeightNeeded(path, line_of(doc, ("sizes_for",)), unknown[0])
        scales = robot_scales(robot, sizes_for)
        scale_sizes(data, scales)
        applied = {f"{SCALE_PREFIX}{name}": factor for name, factor in scales.items()}
    written = {resolve_robot(name, path.parent): name for name in spec.per_robot}.get(robot)
    for key, value in spec.per_robot.get(written or "", {}).items():
        try:
            _set_dotted(data, key, copy.deepcopy(value))
        except (KeyError, TypeError):
            raise ScenarioError(
                path,
                line_of(doc, ("per_robot", written, key)),
                f"per_robot.{written}.{key}",
                "not a key of the scenario",
            ) from None
    return applied


def _sweep_error(
    path: Path, doc: CommentedMap, spec: ScenarioFile, swept: dict[str, Any], exc: ValidationError
) -> ScenarioError:
    """The error of a swept value, located at the sweep (or randomize) entry that produced it."""
    for err in exc.errors():
        bad = ".".join(str(p) for p in error_location(err, UNION_TAGS))
        key = next((k for k in swept if bad.startswith(k)), None)
        if key is not None:
            single = ValidationError.from_exception_data(exc.title, [err])  # type: ignore[list-item]
            return validation_error(path, doc, single, key_origin(spec, key), UNION_TAGS)
    return validation_error(path, doc, exc, tags=UNION_TAGS)


def key_origin(spec: ScenarioFile, key: str) -> tuple[str, str]:
    """Where a swept or randomised key is written in the file."""
    return ("sweep", key) if key in spec.sweep else ("randomize", key)
