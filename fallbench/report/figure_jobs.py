"""The report's figures as jobs for `drawing.Drawing`: per family 002's figures per point, 004's
top-down plots and the reshaped falls; the forest plots; the figures of metric rows only; 004's
report."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from fallbench.report.drawing import Figure
from fallbench.report.family import Family
from fallbench.report.forest import Pool, forest_figure
from fallbench.report.papers.direction import direction_report
from fallbench.report.papers.direction_top_down import top_down_figure
from fallbench.report.papers.drop_figures import draw_paper_figures, paper_points
from fallbench.report.papers.figures_004 import mirrors
from fallbench.report.papers.reshape import (
    draw_reshaped_falls,
    first_impact_figure,
    reshape_points,
)
from fallbench.report.sensitivity import SWEEPS, sensitivity_figure, sensitivity_runs
from fallbench.report.sweeps import KEY_METRICS, distribution_figure, parameter_figures
from fallbench.results import store


def _paper_rows(family: Family, results: Path, which: str) -> list[tuple[str, pd.DataFrame]]:
    """The points of a family that get 002's figures, as (point, its runs): with "all" every
    eligible point (`papers.drop_figures.paper_points`; runs stored with their time series); with "chosen" one:
    the point of its worst shown fall if eligible, else of its other shown falls in order, else
    its first eligible point."""
    eligible = paper_points(store.with_timeseries(results, family.runs))  # not --timeseries none
    if which == "all" or not eligible:
        return eligible
    by_point = dict(eligible)
    shown = sorted(family.picks, key=lambda p: p.role != "worst")  # the worst first, then in order
    point = next((p.point for p in shown if p.point in by_point), eligible[0][0])
    return [(point, by_point[point])]


def per_family_paper_jobs(
    families: list[Family], results: Path, out: Path, which: str = "chosen"
) -> dict[str, list[Figure]]:
    """Family stem -> the figures of 002 per point (`_paper_rows`), 004's top-down plots (`none`
    and `direction` on the same point and policy, with a control origin) and the reshaped falls
    (each family's typical `reshape` fall, `papers.reshape.reshape_points`)."""
    jobs: dict[str, list[Figure]] = {}
    for family in families:
        mine = [
            Figure(
                f"002:{family.robot}:{point}",
                draw_paper_figures,
                (_slim(rows), results, out, point),
                tuple(rows.run_id),
            )
            for point, rows in _paper_rows(family, results, which)
        ]
        mine += _top_down_jobs(family, results, out)
        mine += [
            Figure(
                f"reshape:{family.robot}:{point}:{policy}",
                draw_reshaped_falls,
                (rows, results, out, point, policy),
                tuple(rows.run_id),
            )
            for point, policy in reshape_points([p for p in family.arm_picks if p.role == "typical"])
            for rows in [_one_run_each(family, point, policy)]
        ]
        jobs[family.stem] = mine
    return jobs


def _top_down_jobs(family: Family, results: Path, out: Path) -> list[Figure]:
    """004's top-down plots of the family's chosen `direction` falls (the mirrors of 004's figures
    get theirs from `direction_report`)."""
    if family.name in mirrors(family.runs, results):
        return []
    jobs = []
    for pick in family.picks:
        if pick.pre_impact != "direction":
            continue
        rows = _one_run_each(family, pick.point, pick.policy, pick.run_id)
        if {"none", "direction"} <= set(rows.pre_impact) and "direction_origin_x" in rows:
            jobs.append(
                Figure(
                    f"004:{family.robot}:{pick.point}:{pick.policy}",
                    top_down_figure,
                    (rows, results, out, pick.point, pick.policy),
                    tuple(rows.run_id),
                )
            )
    return list({job.name: job for job in jobs}.values())


def _one_run_each(family: Family, point: str, policy: str, chosen: str = "") -> pd.DataFrame:
    """The point's successful runs under `policy`, one per strategy: the chosen run for its own
    strategy, else the smallest run id (a store may hold the same point twice, e.g. run by two
    versions of fallbench)."""
    rows = family.runs[
        (family.runs.point == point) & (family.runs.policy == policy) & (family.runs.status == "ok")
    ]
    rows = rows.assign(first=rows.run_id != chosen).sort_values(["first", "run_id"])
    return rows.drop_duplicates("pre_impact").drop(columns="first").sort_values("run_id")


def _slim(rows: pd.DataFrame) -> pd.DataFrame:
    """The columns the figures of 002 read: fewer cells to hash and to send to a worker."""
    return rows[[c for c in ("run_id", "robot", "robot_card", "point", "policy", "impact_time") if c in rows]]


def forest_jobs(pooled: dict[str, list[Pool]], families: list[Family], out: Path) -> list[Figure]:
    """The overview's forest plots per robot (one per pool of families with the same arms) and one
    per family."""
    jobs = []
    for robot, robot_pools in pooled.items():
        total = sum(f.robot == robot for f in families)
        for k, pool in enumerate(robot_pools):
            title = f"Change against none + stiff on the same point and seed; {pool.title(robot, total)}"
            stem = f"forest_{robot or 'all'}" + (f"_{k + 1}" if k else "")
            jobs.append(Figure(f"forest:{robot}:{k}", forest_figure, (pool.changes, title, out, stem)))
    for family in families:
        title = f"{family.title}: change against none + stiff on the same point and seed"
        jobs.append(
            Figure(
                f"forest:{family.stem}", forest_figure, (family.changes, title, out, f"forest_{family.stem}")
            )
        )
    return jobs


def summary_figure_jobs(runs: pd.DataFrame, out: Path) -> list[Figure]:
    """Figures of metric rows only: distributions, metrics vs swept values, first impacts, sensitivity."""
    ok = runs[runs.status == "ok"]
    jobs = [Figure("sweeps:distributions", distribution_figure, (ok[["policy", *KEY_METRICS]], out))]
    keep = ["robot", "scenario", "pre_impact", "policy", *KEY_METRICS]
    for (robot, family), group in ok.groupby(["robot", "scenario"]):
        params = [c for c in group.columns if c.startswith("param:") and group[c].notna().any()]
        if params:
            jobs.append(Figure(f"sweeps:{robot}:{family}", parameter_figures, (group[keep + params], out)))
    if "first_impact_group" in runs:
        jobs.append(Figure("preimpact:first_impact", first_impact_figure, (runs, out)))
    for sweep in SWEEPS:
        swept = sensitivity_runs(runs, sweep)
        if len(swept):
            jobs.append(Figure(f"sensitivity:{sweep.name}", sensitivity_figure, (swept, out, sweep)))
    return jobs


def direction_job(runs: pd.DataFrame, results: Path, out: Path) -> list[Figure]:
    """004's report (`direction_report`: figures and tables) as one job, on the families with
    `direction` runs."""
    families = runs.loc[runs.pre_impact == "direction", "scenario"].unique()
    mine = runs[runs.scenario.isin(families)]
    if mine.empty:
        return []
    return [Figure("004:report", direction_report, (mine, results, out), tuple(mine.run_id))]
