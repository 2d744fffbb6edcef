"""The report groups every table and figure by robot, and reads one run per fall (the newest)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from fallbench.results import store
from fallbench.robots import DEFAULT_ROBOT, robot_names


def with_robot(runs: pd.DataFrame) -> pd.DataFrame:
    """Runs with a `robot` column that names the robot as the report shows it (`robot_names`: a
    card's `name`, never its path; in the point labels too), and a `robot_card` column with the
    robot as stored (the card's path), which the figures that read the robot's model use. Runs
    stored before the `robot` column existed ran on the default robot."""
    if "robot_card" in runs:  # named already
        return runs
    robot = (
        runs["robot"].fillna(DEFAULT_ROBOT) if "robot" in runs else pd.Series(DEFAULT_ROBOT, index=runs.index)
    )
    names = robot_names(list(robot.unique()))
    runs = runs.assign(robot=robot.map(names), robot_card=robot)
    for stored, name in names.items():  # a card's point labels hold its path (`robot=<card>`) too
        if stored != name:
            mine = runs.robot_card == stored
            for column in ("point", "group"):
                if column in runs:
                    runs.loc[mine, column] = runs.loc[mine, column].map(
                        lambda label, stored=stored, name=name: named_point(label, stored, name)
                    )
    return runs


def named_point(point: str, robot: str, name: str | None = None) -> str:
    """A stored point label with its robot as the report names it (`robot=<card path>` becomes
    `robot=<card name>`; `name`: the robot's name, by default `robot_names` of it alone)."""
    if name is None:
        name = robot_names([robot])[robot]
    return point.replace(f"robot={robot}", f"robot={name}")


RUN_KEY = ("robot", "scenario", "point", "seed", "physics_dt", "pre_impact", "policy")  # one fall


def stored_time(results: Path, run_id: str) -> float:
    """When a run was stored: the modification time (s since the epoch) of its row file
    (`runs/<id>/metrics.json`, or `metrics.parquet` of older stores), written once when the run
    finished (`cp -a` and `rsync -a` keep it); -inf for a row without a run folder (a store of rows
    only). The row itself holds no time of its own."""
    folder = store.run_dir(results, run_id)
    for name in (store.METRICS_JSON, store.METRICS):
        try:
            return (folder / name).stat().st_mtime
        except OSError:
            continue
    return float("-inf")


def newest_runs(runs: pd.DataFrame, results: Path) -> tuple[pd.DataFrame, int]:
    """One row per fall (RUN_KEY): the run stored last (`stored_time`; ties: the larger run id),
    and how many older rows of the same fall were set aside. A store holds a fall twice when
    `fallbench run sweep` ran again after a code change (the run id includes the code version)."""
    key = [c for c in RUN_KEY if c in runs]
    duplicated = runs.duplicated(key, keep=False)
    if not duplicated.any():
        return runs, 0
    times = runs.run_id.where(duplicated).map(lambda rid: stored_time(results, rid) if pd.notna(rid) else 0.0)
    order = runs.assign(_stored=times).sort_values(["_stored", "run_id"], kind="stable")
    newest = order.drop_duplicates(key, keep="last").drop(columns="_stored").sort_values("run_id")
    return newest, len(runs) - len(newest)


def settled_runs(runs: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(runs that came to rest before their cap, runs that did not): a run still moving at its cap
    has no final damage to rank. Stores without a `settled` column: every run settled."""
    if "settled" not in runs:
        return runs, runs.iloc[0:0]
    settled = runs.settled.astype(object).fillna(True).astype(bool)
    return runs[settled], runs[~settled]


def unsettled_note(count: int) -> str:
    """ "2 runs did not settle by their cap, left out" (empty for none)."""
    if not count:
        return ""
    return f"{count} run{'s' if count > 1 else ''} did not settle by {'their' if count > 1 else 'its'} cap, left out"
