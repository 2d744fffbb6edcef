"""What the commands share: the error exit, scenario files loaded with their errors as one line,
the checked names of policies, strategies and robots, and the choice of sweep points."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import typer

from fallbench.scenario import ScenarioError, ScenarioPoint


def fail(message: str, code: int = 2) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def _load(files: list[Path], robot: str | None = None) -> list[ScenarioPoint]:
    try:
        from fallbench.checks import load

        return load(list(files), robot)
    except ScenarioError as exc:
        fail(str(exc))
    raise AssertionError  # unreachable: fail() exits


def _names(text: str, known: Iterable[str], option: str, what: str) -> list[str]:
    """A comma-separated option's names, each checked against the known ones."""
    names = [p.strip() for p in text.split(",") if p.strip()]
    for name in names:
        if name not in known:
            fail(f"{option}: unknown {what} {name!r}; known: {', '.join(known)}")
    return names


def _policies(text: str) -> list[str]:
    from fallbench.registry import POLICIES

    return _names(text, POLICIES, "--policies", "policy")


def _robot(name: str | None, option: str = "--robot") -> str | None:
    """A robot option or argument: a shipped robot's name, or a robot card's path (from the
    current folder), made absolute."""
    from fallbench.robots import resolve_robot, robot_problem

    if name is None:
        return None
    robot = resolve_robot(name.strip(), Path.cwd())
    problem = robot_problem(robot)
    if problem:
        fail(f"{option}: {problem}")
    return robot


def _strategies(text: str) -> list[str]:
    from fallbench.registry import STRATEGIES

    return _names(text, STRATEGIES, "--pre-impact", "strategy")


PRE_IMPACT_HELP = "Comma-separated pre-impact strategies (none, reshape, direction, onnx, or a plugin's); a scenario's own `pre_impact` list wins. `onnx` (a learned whole-fall policy, `policy_params.onnx.model`) runs once per point with the policy `-`."


def _matching(points: list[ScenarioPoint], selectors: list[str], file: Path) -> list[ScenarioPoint]:
    """The points of a file's sweep that `--point 3` (index) or `--point key=value` (repeatable) select."""
    chosen = points
    for selector in selectors:
        if selector.isdigit():
            index = int(selector)
            if index >= len(points):
                fail(f"{file}: --point {index}: the file has {len(points)} points (0..{len(points) - 1})")
            chosen = [points[index]]
            continue
        key, _, value = selector.partition("=")
        if not value:
            fail(f"--point {selector!r}: expected an index or key=value")
        chosen = [
            p
            for p in chosen
            if (
                _same(p.swept[key], value)
                if key in p.swept
                else key == "robot" and _same(p.scenario.robot, value)
            )
        ]
    return chosen


def _select(points: list[ScenarioPoint], selectors: list[str], file: Path) -> ScenarioPoint:
    """Exactly one point of a file's sweep (see `_matching`)."""
    chosen = _matching(points, selectors, file)
    if len(chosen) != 1:
        labels = "\n  ".join(f"{i}: {p.label}" for i, p in enumerate(points))
        fail(f"{file}: --point selects {len(chosen)} points, need exactly 1; the points are:\n  {labels}")
    return chosen[0]


def _same(swept: object, text: str) -> bool:
    try:
        return abs(float(swept) - float(text)) < 1e-9  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(swept) == text
