"""Reading scenario files: YAML with file:line errors, each document validated against the
schema, expanded and checked point by point; a file's documents reseeded for the Gymnasium
environment."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from ruamel.yaml.comments import CommentedMap

from fallbench.robots import resolve_robot, robot_problem
from fallbench.scenario.hashing import scenario_hash
from fallbench.scenario.schema import MAX_POINTS_PER_FILE, UNION_TAGS, Scenario, ScenarioError, ScenarioFile
from fallbench.scenario.sweep import ScenarioPoint, expand_points, key_origin
from fallbench.yamlfile import line_of, plain, read_yaml, validation_error

KIND = "scenario file"  # how messages name the file

Check = Callable[[Scenario], "tuple[str, str] | None"]  # (key, reason) of a scenario's first problem, or None


def load_scenario_file(
    path: Path | str, robot: str | None = None, check: Check | None = None
) -> list[ScenarioPoint]:
    """Parse, validate and expand one scenario file; raises ScenarioError on any bad input.
    `robot` replaces the file's robot (and any sweep over robots). `check` sees each distinct point
    for problems the schema cannot (robot, scene, controllers: `fallbench.registry.check_scenario`);
    its key is located in the file."""
    path = Path(path)
    return [point for doc in read_yaml(path, KIND) for point in _load_document(path, doc, robot, check)]


def _load_document(
    path: Path, doc: CommentedMap, robot: str | None, check: Check | None
) -> list[ScenarioPoint]:
    try:
        spec = ScenarioFile.model_validate(plain(doc))
    except ValidationError as exc:
        raise validation_error(path, doc, exc, tags=UNION_TAGS) from None
    for key, (low, high) in spec.randomize.items():
        if low > high:
            raise ScenarioError(
                path, line_of(doc, ("randomize", key)), f"randomize.{key}", f"empty range [{low}, {high}]"
            )
    for key, values in spec.sweep.items():
        if not values:
            raise ScenarioError(path, line_of(doc, ("sweep", key)), f"sweep.{key}", "empty list of values")
    for key, names in (
        ("sizes_for", [spec.sizes_for] if spec.sizes_for else []),
        ("per_robot", list(spec.per_robot)),
    ):
        for name in names:
            problem = robot_problem(resolve_robot(name, path.parent))
            if problem:
                raise ScenarioError(path, line_of(doc, (key,)), key, problem)
    count = math.prod(len(values) for values in spec.sweep.values()) * spec.seeds
    if count > MAX_POINTS_PER_FILE:
        raise ScenarioError(
            path,
            line_of(doc, ("sweep",)) or line_of(doc, ("seeds",)),
            "sweep",
            f"{count:,} points (sweep values x seeds), over the limit of {MAX_POINTS_PER_FILE:,} per file",
        )
    points = expand_points(path, doc, spec, robot)
    if check is None:
        return points
    checked: set[str] = set()
    for point in points:
        fingerprint = scenario_hash(point.scenario.model_copy(update={"seed": 0}))
        if fingerprint in checked:
            continue
        checked.add(fingerprint)
        problem = check(point.scenario)
        if problem:
            key, reason = problem
            loc = tuple(int(p) if p.isdigit() else p for p in key.split("."))
            origin = next((key_origin(spec, k) for k in point.swept if key.startswith(k)), loc)
            raise ScenarioError(path, line_of(doc, origin) or line_of(doc, loc), key, reason)
    return points


def load_scenarios(
    paths: list[Path] | list[Path | str], robot: str | None = None, check: Check | None = None
) -> list[ScenarioPoint]:
    return [point for path in paths for point in load_scenario_file(path, robot, check)]


def read_documents(path: Path | str) -> list[Any]:
    """A scenario file's YAML documents, parsed once (for `points_with_seed`)."""
    return read_yaml(Path(path), KIND)


def points_with_seed(
    path: Path | str, documents: list[Any], seed: int, robot: str | None = None
) -> list[ScenarioPoint]:
    """Every sweep point of a scenario file's `documents` drawn with `seed` in place of the file's
    seeds (its randomised keys and posture noise): a Gymnasium environment draws a fresh fall at
    every reset. Not checked against the robot or the controllers: load the file once with
    `load_scenario_file` and a check first."""
    points = []
    for doc in documents:
        reseeded = copy.deepcopy(doc)
        reseeded["seed"], reseeded["seeds"] = seed, 1
        points += _load_document(Path(path), reseeded, robot, None)
    return points
