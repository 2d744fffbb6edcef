"""The answer first: per robot and scenario family, which (pre-impact strategy, gain policy) hurts
the robot least, on the key damage measures, with bootstrap intervals over points and seeds."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from fallbench.report.stats import Estimate, bootstrap, natural_key
from fallbench.report.style import ordered


@dataclass(frozen=True)
class Measure:
    column: str
    label: str
    lower_is_better: bool = True
    statistic: str = "median"  # "mean" for booleans: the fraction of runs


DAMAGE_MEASURES = (
    Measure("imu_peak_z_landing", "landing IMU z peak (m/s²)"),
    Measure("contact_force_peak_head", "head peak force (N)"),
    Measure("contact_force_peak_torso", "torso peak force (N)"),
    Measure("knee_limit_margin", "knee margin (rad)", lower_is_better=False),
    Measure("joint_limit_hits", "joints past a limit"),
    Measure("vulnerable_hits", "vulnerable parts hit"),
    Measure("fell", "fell (fraction)", statistic="mean"),
)
FALLBACKS = {"imu_peak_z_landing": ("imu_peak_z", "IMU z peak, whole run (m/s²)")}
REFERENCE = ("none", "stiff")  # the unprotected fall the learning literature compares against
RELATIVE_MEASURES = {  # column -> label; changes in % of the reference run
    "contact_force_peak_bw": "peak contact force",
    "contact_force_peak_head_bw": "head peak force",
    "contact_force_peak_torso_bw": "torso peak force",
    "torque_peak_legs": "leg torque peak",
    "torque_peak_arms": "arm torque peak",
}
COUNT_MEASURES = {"vulnerable_hits": "vulnerable parts hit"}  # changes as differences of counts


def measures_for(runs: pd.DataFrame) -> list[Measure]:
    """The damage measures this store has (the landing IMU peak falls back to the whole run's)."""
    found = []
    for measure in DAMAGE_MEASURES:
        if measure.column in runs:
            found.append(measure)
        elif measure.column in FALLBACKS and FALLBACKS[measure.column][0] in runs:
            column, label = FALLBACKS[measure.column]
            found.append(Measure(column, label, measure.lower_is_better, measure.statistic))
    return found


def robots(runs: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """Runs per robot; a store without a `robot` column is one robot."""
    if "robot" not in runs:
        return {"": runs}
    return {str(robot): group for robot, group in sorted(runs.groupby("robot"))}


def families(runs: pd.DataFrame) -> list[str]:
    """Scenario families, those with the most runs (the best-supported answers) first."""
    sizes = runs.scenario.value_counts()
    return sorted(runs.scenario.unique(), key=lambda f: (-sizes[f], natural_key(f)))


def _arms(runs: pd.DataFrame) -> list[tuple[str, str]]:
    strategies = sorted(runs.pre_impact.unique(), key=lambda s: (s != "none", s))
    return [(s, p) for s in strategies for p in ordered(runs[runs.pre_impact == s].policy.unique())]


def estimates(runs: pd.DataFrame) -> dict[tuple[str, str], dict[str, Estimate]]:
    """(strategy, policy) -> measure column -> estimate over the family's ok runs (points x seeds)."""
    ok = runs[runs.status == "ok"]
    return {
        (s, p): {
            m.column: bootstrap(
                ok.loc[(ok.pre_impact == s) & (ok.policy == p), m.column].astype(float), m.statistic
            )
            for m in measures_for(runs)
        }
        for s, p in _arms(ok)
    }


Ranked = tuple[pd.DataFrame, dict[tuple[str, str], dict[str, Estimate]], list[Measure]]


def ranked(runs: pd.DataFrame) -> Ranked:
    """The ranking table, the estimates behind it and the measures: computed once per family and
    handed to `verdict` and `arm_order` (each bootstrap costs milliseconds)."""
    return _ranked(runs)


def _ranked(runs: pd.DataFrame) -> Ranked:
    found = measures_for(runs)
    table = estimates(runs)
    if not table:
        return pd.DataFrame(), table, found
    values = pd.DataFrame({arm: {m.column: e[m.column].value for m in found} for arm, e in table.items()}).T
    ranks = pd.DataFrame({m.column: values[m.column].rank(ascending=m.lower_is_better) for m in found})
    rows = []
    for arm, per_measure in table.items():
        row = {
            "pre_impact": arm[0],
            "policy": arm[1],
            "mean rank": round(float(ranks.loc[arm].mean()), 2),
            "runs": max(e.n for e in per_measure.values()),
        }
        row.update({m.label: per_measure[m.column].format() for m in found})
        rows.append(row)
    ranking = (
        pd.DataFrame(rows)
        .sort_values(["mean rank", "pre_impact", "policy"], kind="stable")
        .reset_index(drop=True)
    )
    return ranking, table, found


def arm_order(runs: pd.DataFrame, done: Ranked | None = None) -> list[tuple[str, str]]:
    """The (strategy, policy) pairs of `runs` in the ranking table's order, best first."""
    table = (done or _ranked(runs))[0]
    return list(zip(table.pre_impact, table.policy)) if len(table) else []


def ranking_table(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (strategy, policy), best first: mean rank over the damage measures (1 = least
    damage on every measure; ties share a rank), runs, and each measure's median [95 % CI]
    (`fell`: the fraction of runs)."""
    return _ranked(runs)[0]


def verdict(runs: pd.DataFrame, done: Ranked | None = None) -> str:
    """One line: the arm with the best mean rank, and on which measures its interval is clear of
    the runner-up's (otherwise the data do not separate them)."""
    table, est, found = done or _ranked(runs)
    if len(table) == 0:
        return "no successful runs"
    best = table.iloc[0]
    name = f"{best.pre_impact} + {best.policy}"
    if len(table) == 1:
        return f"only {name} ran"
    second = table.iloc[1]
    first_arm, second_arm = (best.pre_impact, best.policy), (second.pre_impact, second.policy)
    clear = [
        m.label.split(" (")[0] for m in found if est[first_arm][m.column].disjoint(est[second_arm][m.column])
    ]
    line = f"least damage: {name} (mean rank {best['mean rank']:g} of {len(table)} over {len(found)} measures, {int(best.runs)} runs)"
    if int(best.runs) < 2:
        return line + "; one run each, so no interval: a ranking of single falls, not of distributions"
    if clear:
        return (
            line
            + f"; its 95 % interval is clear of the runner-up's ({second.pre_impact} + {second.policy}) on "
            + ", ".join(clear)
        )
    return (
        line
        + f"; its intervals overlap the runner-up's ({second.pre_impact} + {second.policy}) on every measure: no clear winner"
    )


def relative_changes(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (strategy, policy): the change of each damage measure against the `none` + `stiff` run
    of the same point and seed (median [95 % CI] over points and seeds): peak forces and torques
    in % of the reference, counts as differences."""
    ok = runs[runs.status == "ok"]
    columns = [c for c in (*RELATIVE_MEASURES, *COUNT_MEASURES) if c in ok]
    key = ["robot", "point"] if "robot" in ok else ["point"]
    reference = ok[(ok.pre_impact == REFERENCE[0]) & (ok.policy == REFERENCE[1])][key + columns]
    if reference.empty or not columns:
        return pd.DataFrame()
    reference = reference.drop_duplicates(key)
    rows = []
    for strategy, policy in _arms(ok):
        if (strategy, policy) == REFERENCE:
            continue
        # each run of the arm with its reference run's values (NaN where the point has none)
        joined = ok[(ok.pre_impact == strategy) & (ok.policy == policy)][key + columns].merge(
            reference, on=key, how="left", suffixes=("", ":reference")
        )
        arm = joined[columns].astype(float)
        ref = joined[[f"{c}:reference" for c in columns]].astype(float).set_axis(columns, axis=1)
        row: dict[str, object] = {
            "pre_impact": strategy,
            "policy": policy,
            "paired runs": int(ref[columns[0]].notna().sum()),
        }
        for column in columns:
            if column in COUNT_MEASURES:
                row[f"{COUNT_MEASURES[column]} (difference)"] = bootstrap(
                    arm[column] - ref[column], "mean"
                ).format(2)
            else:
                change = 100 * (arm[column] - ref[column]) / ref[column].where(ref[column] > 0)
                row[f"{RELATIVE_MEASURES[column]} (%)"] = bootstrap(change).format(2)
        rows.append(row)
    return pd.DataFrame(rows)
