"""Which runs a table or figure reads, told by what the store holds about each run, never by its
scenario's name: whether it started in the air, was pushed, fell among objects, whether its
conditions were set or drawn at random, whether its objects were ever within reach."""

from __future__ import annotations

import pandas as pd

HEIGHT = "param:initial.height"  # m: set by every drop scenario, swept or drawn
PUSH_DIRECTION = "param:push.direction"  # deg, 0 = robot forward
FREE_SPACE_CLEARANCE = 2.0  # m: the obstacle outcome's largest clearance (farther is reported as this)


def _present(runs: pd.DataFrame, column: str) -> pd.Series:
    """Whether each run has a value in `column` (False for all when the store lacks it)."""
    return runs[column].notna() if column in runs else pd.Series(False, index=runs.index)


def dropped(runs: pd.DataFrame) -> pd.Series:
    """Runs that started in the air: their scenario sets the initial height (a swept or drawn value)."""
    return _present(runs, HEIGHT)


def pushed(runs: pd.DataFrame) -> pd.Series:
    """Runs whose scenario sweeps or draws a push (force, direction, duration or start)."""
    columns = [c for c in runs.columns if c.startswith("param:push.")]
    return runs[columns].notna().any(axis=1) if columns else pd.Series(False, index=runs.index)


def among_objects(runs: pd.DataFrame) -> pd.Series:
    """Runs with objects in the scene: the obstacle outcome (hit or not) is recorded only there."""
    return _present(runs, "obstacle_hit")


def set_conditions(runs: pd.DataFrame) -> pd.Series:
    """Runs whose conditions were all set, none drawn at random from the seed: the point's label
    without its seed is its `group` (which leaves drawn values out). Stores without `group`: all."""
    if "group" not in runs:
        return pd.Series(True, index=runs.index)
    return runs.point.str.rsplit("#s", n=1).str[0] == runs.group


def pushed_at_set_direction(runs: pd.DataFrame) -> pd.Series:
    """Pushes on open ground whose direction was set (swept), not drawn: the falls 000's landing
    order is read on, labelled front, back, side or diagonal by that direction."""
    return _present(runs, PUSH_DIRECTION) & set_conditions(runs) & ~among_objects(runs)


def free_space(runs: pd.DataFrame) -> pd.Series:
    """Runs of families among objects none of whose runs came within FREE_SPACE_CLEARANCE m of an
    object at impact: the objects are markers that make the outcome metrics run (e.g. the steering
    authority suite), not obstacles."""
    if "obstacle_clearance_at_impact" not in runs or runs.empty:
        return pd.Series(False, index=runs.index)
    family = [c for c in ("robot", "scenario") if c in runs]
    clear = (runs.obstacle_clearance_at_impact >= FREE_SPACE_CLEARANCE).groupby([runs[c] for c in family])
    return among_objects(runs) & clear.transform("all")
