"""Which falls the report shows as filmstrips, chosen by the data, not by scenario names.

A run's **damage** is a number in [0, 1] within its robot and scenario family: the mean, over the
family's damage measures (`measures_for`: landing IMU z peak, head and torso peak forces,
knee margin, joints past a limit, vulnerable parts hit, fell), of the run's percentile rank among
the family's successful runs on that measure, oriented so that 1 is the most damage (the lowest
knee margin, the highest peaks and counts, a fall). Ties share their mean rank; a measure the run
lacks (NaN) is left out of its mean.

For each (pre-impact strategy, gain policy) of a family the report shows two falls: the **typical**
one, the run whose damage is nearest the median damage of that strategy and policy's runs in the
family (ties: the smaller run id), and the **worst** one, its run of the highest damage (the same
run once when they coincide, e.g. one run per strategy and policy): `scope="all"`
(`fallbench report --filmstrips all`).

By default (`scope="family"`) a family shows at most three falls: the typical fall of its best
(strategy, policy) (the ranking's first), the typical fall of the unprotected reference `none` +
`stiff`, and the family's **worst** fall over every strategy and policy (ties: the smaller run id)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from fallbench.report.drawing import Figure
from fallbench.report.figure_files import FigureSkipped
from fallbench.report.ranking import arm_order, families, measures_for, robots
from fallbench.report.render import RenderUnavailable, ReplayMissing, filmstrip


@dataclass(frozen=True)
class Pick:
    """One representative fall of a (strategy, policy) in a family."""

    robot: str
    family: str
    pre_impact: str
    policy: str
    role: str  # "typical" or "worst"
    run_id: str
    damage: float
    point: str


def damage(family: pd.DataFrame) -> pd.Series:
    """Each successful run's damage in [0, 1] (see the module's docstring), indexed like `family`."""
    ok = family[family.status == "ok"]
    ranks = []
    for measure in measures_for(ok):
        values = ok[measure.column].astype(float)
        if values.notna().sum() == 0:
            continue
        # pct ranks: (1..n)/n; higher value = more damage unless higher is better (knee margin)
        rank = values.rank(pct=True, ascending=measure.lower_is_better)
        ranks.append(rank.rename(measure.column))
    if not ranks:
        return pd.Series(float("nan"), index=ok.index)
    return pd.concat(ranks, axis=1).mean(axis=1, skipna=True)


SCOPES = ("family", "all")  # `fallbench report --filmstrips`: see the module's docstring
REFERENCE = ("none", "stiff")  # the unprotected fall every change is measured against


def picks(runs: pd.DataFrame, scope: str = "all") -> list[Pick]:
    """Per robot and family (the report's grouping) the representative falls of `scope` (see the
    module's docstring), in ranking order."""
    chosen: list[Pick] = []
    for robot, robot_runs in robots(runs).items():
        for family in families(robot_runs):
            group = robot_runs[robot_runs.scenario == family]
            chosen += family_picks(robot, family, group, arm_order(group), scope)
    return chosen


def family_picks(
    robot: str, family: str, group: pd.DataFrame, arms: list[tuple[str, str]], scope: str = "all"
) -> list[Pick]:
    """One family's representative falls (`arms`: its (strategy, policy) best first): with
    `scope="all"` the typical and the worst fall of each; with "family" the typical fall of the
    best and of `none` + `stiff`, and the family's worst fall."""
    if scope not in SCOPES:
        raise ValueError(f"scope: {scope!r} is not one of {', '.join(SCOPES)}")
    scores = damage(group).dropna()
    if scores.empty:
        return []
    shown = ["run_id", "pre_impact", "policy", "point"]  # what a Pick keeps: rows of 4 cells, not hundreds
    scored = group.loc[scores.index, shown].assign(damage=scores).sort_values("run_id")

    def pick(role: str, index) -> Pick:
        row = scored.loc[index]
        return Pick(robot, family, row.pre_impact, row.policy, role, row.run_id, float(row.damage), row.point)

    chosen = []
    for strategy, policy in arms:
        arm = scored[(scored.pre_impact == strategy) & (scored.policy == policy)]
        if arm.empty or (scope == "family" and (strategy, policy) not in (_best(scored, arms), REFERENCE)):
            continue
        typical = (arm.damage - arm.damage.median()).abs().idxmin()  # first of ties: the smaller id
        chosen.append(pick("typical", typical))
        if scope == "all" and arm.damage.idxmax() != typical:
            chosen.append(pick("worst", arm.damage.idxmax()))
    worst = scored.damage.idxmax()  # first of ties: the smaller id
    if scope == "family" and scored.run_id[worst] not in {p.run_id for p in chosen}:
        chosen.append(pick("worst", worst))
    return chosen


def _best(scored: pd.DataFrame, arms: list[tuple[str, str]]) -> tuple[str, str] | None:
    """The first of `arms` (best first) with a scored run."""
    present = set(zip(scored.pre_impact, scored.policy))
    return next((arm for arm in arms if arm in present), None)


def draw_filmstrip(results: Path, run_id: str, out: Path) -> list[Path]:
    """One run's filmstrip; a run that cannot be rendered is skipped with the reason."""
    try:
        return [filmstrip(results, run_id, out)]
    except (RenderUnavailable, ReplayMissing) as exc:
        raise FigureSkipped(str(exc)) from None


def figure_name(run_id: str) -> str:
    return f"filmstrip:{run_id}"


def filmstrip_figures(
    chosen: list[Pick], results: Path, out: Path, among_objects: frozenset[str] = frozenset()
) -> list[Figure]:
    """One figure per chosen run (a run chosen twice is drawn once), those of one robot and family
    next to each other. Runs that look alike are one drawing group, drawn in turn by one worker
    with the renderer of their scene (made once, ~0.35 s): a robot's runs on open ground, and
    each family's runs among objects (`among_objects`: their run ids)."""
    ordered = sorted(chosen, key=lambda p: (p.robot, p.family))  # stable: ranking order within
    scene = {p.run_id: f"{p.robot}:{p.family if p.run_id in among_objects else ''}" for p in ordered}
    run_ids = list(dict.fromkeys(p.run_id for p in ordered))
    return [
        Figure(figure_name(r), draw_filmstrip, (results, r, out), (r,), f"scene:{scene[r]}") for r in run_ids
    ]
