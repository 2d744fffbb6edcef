"""Scenario files: schema, YAML loading with file:line errors, sweep expansion, content hash.

A scenario YAML describes a family of falls. `load_scenarios` validates it completely (schema,
sweep points, robot names, obstacles against the robot's start pose) before anything runs, and
`expand` turns it into one `RunSpec` per (sweep point, seed, policy, pre-impact strategy).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import MarkedYAMLError

PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Initial(Strict):
    posture: str = "half_sitting"
    height: NonNegativeFloat = 0.0  # m between the feet and the floor at t = 0
    joints: dict[str, float] = {}  # rad, overrides of the posture
    joint_noise: Annotated[float, Field(ge=0, le=0.5)] = 0.0  # rad, half-width of a uniform offset per joint, drawn from the seed


class Push(Strict):
    force: NonNegativeFloat  # N
    direction: float = 0.0  # deg in the ground plane; 0 = robot forward, 90 = robot left
    duration: PositiveFloat = 0.2  # s
    start: NonNegativeFloat = 0.1  # s
    body: str | None = None  # default: the robot's torso


class Box(Strict):
    type: Literal["box"]
    pos: tuple[float, float, float]  # m, centre in the world
    size: tuple[PositiveFloat, PositiveFloat, PositiveFloat]  # m, full extents
    yaw: float = 0.0  # deg


class Cylinder(Strict):
    type: Literal["cylinder"]
    pos: tuple[float, float, float]  # m, centre in the world
    radius: PositiveFloat  # m
    height: PositiveFloat  # m


Obstacle = Annotated[Union[Box, Cylinder], Field(discriminator="type")]


class Detection(Strict):
    tilt: Annotated[float, Field(gt=0, lt=90)] = 15.0  # deg of torso tilt that declares a fall (000)
    freefall: NonNegativeFloat = 3.0  # m/s^2: accelerometer norm below this declares free fall
    freefall_hold: NonNegativeFloat = 0.02  # s the accelerometer must read free fall


class Scenario(Strict):
    """One fully resolved scenario point (no sweep left)."""

    name: str
    robot: str = "talos"
    duration: PositiveFloat  # s
    physics_dt: PositiveFloat = 0.001  # s
    control_dt: PositiveFloat = 0.005  # s
    friction: PositiveFloat = 0.7
    initial: Initial = Initial()
    push: Push | None = None
    obstacles: list[Obstacle] = []
    detection: Detection = Detection()
    policy_params: dict[str, dict[str, Any]] = {}  # policy (or `reshape`) name -> parameter overrides
    pre_impact: tuple[Literal["none", "reshape"], ...] | None = None  # pins the strategies swept for this scenario
    seed: Annotated[int, Field(ge=0)] = 0

    @model_validator(mode="after")
    def _rates(self) -> "Scenario":
        if self.physics_dt > self.control_dt:
            raise ValueError(
                f"physics_dt ({self.physics_dt} s) must not exceed control_dt ({self.control_dt} s)"
            )
        ratio = self.control_dt / self.physics_dt
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"control_dt ({self.control_dt} s) must be a multiple of physics_dt")
        return self

    @property
    def physics_steps_per_control(self) -> int:
        return round(self.control_dt / self.physics_dt)


class ScenarioFile(Scenario):
    """A scenario file: a base scenario plus sweep, randomisation and seed repetition."""

    randomize: dict[str, tuple[float, float]] = {}
    sweep: dict[str, list[Any]] = {}
    seeds: Annotated[int, Field(ge=1)] = 1


class ScenarioError(ValueError):
    """Bad scenario input: carries file, line and key so the CLI prints one clear line."""

    def __init__(self, path: Path | str, line: int | None, key: str, reason: str) -> None:
        self.path, self.line, self.key, self.reason = str(path), line, key, reason
        where = f"{self.path}:{line}" if line else self.path
        super().__init__(f"{where}: {key}: {reason}" if key else f"{where}: {reason}")


@dataclass(frozen=True)
class ScenarioPoint:
    """One point of a scenario file's sweep, with the values that made it."""

    scenario: Scenario
    swept: dict[str, Any]  # dotted key -> value, sweep and randomised keys
    source: str  # file the point came from

    @property
    def label(self) -> str:
        parts = [f"{k}={_fmt(v)}" for k, v in self.swept.items() if not k.startswith("randomize:")]
        return self.scenario.name + ("[" + ",".join(parts) + "]" if parts else "") + f"#s{self.scenario.seed}"


def _fmt(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


# ---------------------------------------------------------------- YAML with line numbers

def _line_of(doc: Any, loc: tuple[Any, ...]) -> int | None:
    """1-based line of the deepest node of `loc` that exists in the parsed YAML."""
    node, line = doc, None
    for part in loc:
        if isinstance(node, CommentedMap) and part in node:
            line = node.lc.key(part)[0] + 1
            node = node[part]
        elif isinstance(node, CommentedSeq) and isinstance(part, int) and part < len(node):
            line = node.lc.item(part)[0] + 1
            node = node[part]
        else:
            break
    return line


def _read_yaml(path: Path) -> list[CommentedMap]:
    """The YAML documents of a file (several families can share a file, separated by `---`)."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise ScenarioError(path, None, "", f"cannot read file ({exc.strerror})") from None
    try:
        docs = list(YAML(typ="rt").load_all(text))
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        reason = f"malformed YAML: {exc.problem or exc.context}"
        if exc.context and exc.context_mark and exc.problem:
            reason += f" ({exc.context} started at line {exc.context_mark.line + 1})"
        raise ScenarioError(path, line, "", reason) from None
    docs = [doc for doc in docs if doc is not None]
    if not docs:
        raise ScenarioError(path, 1, "", "empty file: expected a scenario mapping")
    for doc in docs:
        if not isinstance(doc, CommentedMap):
            line = doc.lc.line + 1 if hasattr(doc, "lc") else 1
            raise ScenarioError(path, line, "", "a scenario document must be a YAML mapping")
    return docs


def _plain(node: Any) -> Any:
    """ruamel's round-trip containers as plain dicts and lists."""
    if isinstance(node, dict):
        return {str(k): _plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_plain(v) for v in node]
    return node


def _validation_error(path: Path, doc: Any, exc: ValidationError, line_loc: tuple[Any, ...] = ()) -> ScenarioError:
    err = exc.errors()[0]
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p in ("box", "cylinder")))
    key = ".".join(str(p) for p in loc) or "(top level)"
    line = _line_of(doc, line_loc or loc) or 1
    reason = err["msg"]
    if err["type"] == "extra_forbidden":
        reason = "unknown key"
    elif "input" in err and err["type"] not in ("missing",) and not isinstance(err["input"], dict):
        reason += f" (got {err['input']!r})"
    return ScenarioError(path, line, key, reason)


# ---------------------------------------------------------------- sweep expansion

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


def _points(path: Path, doc: CommentedMap, spec: ScenarioFile) -> list[ScenarioPoint]:
    base = _plain(doc)
    for key in ("sweep", "randomize", "seeds"):
        base.pop(key, None)
    sweep_keys = list(spec.sweep)
    points = []
    for values in itertools.product(*(spec.sweep[k] for k in sweep_keys)):
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
                    raise ScenarioError(path, _line_of(doc, _origin(spec, key)), key, "not a key of the scenario") from None
            try:
                scenario = Scenario.model_validate(data)
            except ValidationError as exc:
                raise _sweep_error(path, doc, spec, swept, exc) from None
            points.append(ScenarioPoint(scenario, swept, str(path)))
    return points


def _sweep_error(path: Path, doc: CommentedMap, spec: ScenarioFile, swept: dict[str, Any], exc: ValidationError) -> ScenarioError:
    """The error of a swept value, located at the sweep (or randomize) entry that produced it."""
    for err in exc.errors():
        bad = ".".join(str(p) for p in err["loc"])
        key = next((k for k in swept if bad.startswith(k)), None)
        if key is not None:
            single = ValidationError.from_exception_data(exc.title, [err])  # type: ignore[list-item]
            return _validation_error(path, doc, single, _origin(spec, key))
    return _validation_error(path, doc, exc)


def _origin(spec: ScenarioFile, key: str) -> tuple[str, str]:
    """Where a swept or randomised key is written in the file."""
    return ("sweep", key) if key in spec.sweep else ("randomize", key)


def load_scenario_file(path: Path | str) -> list[ScenarioPoint]:
    """Parse, validate and expand one scenario file; raises ScenarioError on any bad input."""
    path = Path(path)
    return [point for doc in _read_yaml(path) for point in _load_document(path, doc)]


def _load_document(path: Path, doc: CommentedMap) -> list[ScenarioPoint]:
    from fallbench.world import check_scenario  # the world knows robots, bodies and geometry

    try:
        spec = ScenarioFile.model_validate(_plain(doc))
    except ValidationError as exc:
        raise _validation_error(path, doc, exc) from None
    for key, (low, high) in spec.randomize.items():
        if low > high:
            raise ScenarioError(path, _line_of(doc, ("randomize", key)), f"randomize.{key}", f"empty range [{low}, {high}]")
    for key, values in spec.sweep.items():
        if not values:
            raise ScenarioError(path, _line_of(doc, ("sweep", key)), f"sweep.{key}", "empty list of values")
    points = _points(path, doc, spec)
    checked: set[str] = set()
    for point in points:
        fingerprint = scenario_hash(point.scenario.model_copy(update={"seed": 0}))
        if fingerprint in checked:
            continue
        checked.add(fingerprint)
        problem = check_scenario(point.scenario)
        if problem:
            key, reason = problem
            loc = tuple(int(p) if p.isdigit() else p for p in key.split("."))
            origin = next((_origin(spec, k) for k in point.swept if key.startswith(k)), loc)
            raise ScenarioError(path, _line_of(doc, origin) or _line_of(doc, loc), key, reason)
    return points


def load_scenarios(paths: list[Path | str]) -> list[ScenarioPoint]:
    return [point for path in paths for point in load_scenario_file(path)]


def canonical_json(data: Any) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)


def scenario_hash(scenario: Scenario) -> str:
    return hashlib.sha256(canonical_json(scenario.model_dump(mode="json")).encode()).hexdigest()[:16]
