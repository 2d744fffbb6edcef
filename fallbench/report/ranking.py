"""The answer first: per robot and scenario family, which (pre-impact strategy, gain policy) hurts
the robot least, on the key damage measures, with bootstrap intervals over points and seeds."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

import fallbench.report.paired as paired
from fallbench.report.paired import Arm, Measure
from fallbench.report.stats import Estimate, bootstrap, natural_key
from fallbench.report.style import ordered

DAMAGE_MEASURES = (
    Measure("imu_peak_z_landing", "landing IMU z peak (m/s²)"),
    Measure("contact_force_peak_head", "head peak force (N)"),
    Measure("contact_force_peak_torso", "torso peak force (N)"),
    Measure("knee_limit_margin", "knee margin (rad)", lower_is_better=False),
    Measure("joint_limit_hits", "joints past a limit", change="mean"),
    Measure("vulnerable_hits", "vulnerable parts hit", change="mean"),
    Measure("fell", "fell (fraction)", statistic="mean", change="mean"),
)
FALLBACKS = {"imu_peak_z_landing": ("imu_peak_z", "IMU z peak, whole run (m/s²)")}
# A protective arm may make the robot fall in at most this share of the runs none + stiff survives
# (the benchmark's do-no-harm bound); above it the verdict never names the arm, whatever its interval says.
INDUCED_FALL_LIMIT = 0.05


@dataclass(frozen=True)
class Harm:
    """Why the verdict passes over an arm: `label` for the ranking's column, `evidence` the
    numbers the verdict gives."""

    label: str
    evidence: str
    # a paired change clearly worse ("clearly worse than none + stiff on ..."), else induced falls
    interval: bool


def measures_for(runs: pd.DataFrame) -> list[Measure]:
    """The damage measures this store has (the landing IMU peak falls back to the whole run's)."""
    found = []
    for measure in DAMAGE_MEASURES:
        if measure.column in runs:
            found.append(measure)
        elif measure.column in FALLBACKS and FALLBACKS[measure.column][0] in runs:
            column, label = FALLBACKS[measure.column]
            found.append(Measure(column, label, measure.lower_is_better, measure.statistic, measure.change))
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


def _arms(runs: pd.DataFrame) -> list[Arm]:
    strategies = sorted(runs.pre_impact.unique(), key=lambda s: (s != "none", s))
    return [(s, p) for s in strategies for p in ordered(runs[runs.pre_impact == s].policy.unique())]


def estimates(
    runs: pd.DataFrame, arms: list[Arm] | None = None, indexed: paired.ArmRuns | None = None
) -> dict[Arm, dict[str, Estimate]]:
    """(strategy, policy) -> measure column -> estimate over the family's ok runs (points x seeds).
    `indexed`: the ok runs' `paired.ArmRuns`, if already made."""
    ok = runs[runs.status == "ok"] if indexed is None else indexed.ok
    indexed = indexed or paired.ArmRuns(ok)
    return {
        arm: {
            m.column: bootstrap(indexed.values(m.column)[indexed.all_rows(arm)], m.statistic)
            for m in measures_for(runs)
        }
        for arm in (_arms(ok) if arms is None else arms)
    }


@dataclass(frozen=True)
class Ranked:
    """A family's ranking, computed once and handed to `verdict`, `arm_order` and the pages (each
    bootstrap costs milliseconds). One row per group of arms with the same falls pair by pair,
    named by its first arm."""

    table: pd.DataFrame  # best mean rank first; ties keep the arms' order, the verdict calls them ties
    estimates: dict[Arm, dict[str, Estimate]]
    measures: list[Measure]
    same: dict[Arm, list[Arm]]  # a row's arm -> the other arms with the same falls
    harm: dict[Arm, list[Harm]]  # arm -> why the verdict never names it (empty: it may)


def ranked(runs: pd.DataFrame) -> Ranked:
    """Rank the family's arms: groups of identical arms merged (`paired.identical_groups`), each
    row's mean rank over the damage measures, and what pairing with `none` + `stiff` says of it."""
    found = measures_for(runs)
    runs = paired.narrow(runs, found)
    ok = runs[runs.status == "ok"]
    indexed = paired.ArmRuns(ok)
    groups = indexed.identical_groups(_arms(ok), [m.column for m in found])
    table = estimates(runs, [g[0] for g in groups], indexed)
    same = {g[0]: g[1:] for g in groups}
    harm_measures = [m for m in found if m.column in paired.HARM_MEASURES]
    harm = {arm: _harm(indexed, arm, harm_measures) for arm in table}
    if not table:
        return Ranked(pd.DataFrame(), table, found, same, harm)
    values = pd.DataFrame({arm: {m.column: e[m.column].value for m in found} for arm, e in table.items()}).T
    ranks = pd.DataFrame({m.column: values[m.column].rank(ascending=m.lower_is_better) for m in found})
    rows = []
    for arm, per_measure in table.items():
        row = {
            "pre_impact": arm[0],
            "policy": arm[1],
            "mean rank": round(float(ranks.loc[arm].mean()), 2),
            "runs": max(e.n for e in per_measure.values()),
            "clearly worse than none + stiff on": ", ".join(h.label for h in harm[arm]),
        }
        row.update({m.label: per_measure[m.column].format() for m in found})
        if any(same.values()):
            row["same falls as"] = "; ".join(_same_note(ok, arm, other) for other in same[arm])
        rows.append(row)
    ranking = pd.DataFrame(rows).sort_values("mean rank", kind="stable").reset_index(drop=True)
    return Ranked(ranking, table, found, same, harm)


def _harm(indexed: paired.ArmRuns, arm: Arm, harm_measures: list[Measure]) -> list[Harm]:
    """The harm measures on which the arm's paired change against `none` + `stiff` is clearly
    worse, and falls it made in more than INDUCED_FALL_LIMIT of the runs `none` + `stiff` survives."""
    if arm == paired.REFERENCE:
        return []
    worse = []
    pair_rows = indexed.pairs(arm, [m.column for m in harm_measures])
    for measure in harm_measures:
        estimate = bootstrap(paired.change(pair_rows, measure.column), measure.change)
        if paired.clearly_worse(estimate, measure.lower_is_better):
            label = measure.label.split(" (")[0]
            worse.append(Harm(label, f"{label} (paired change {estimate.format()})", interval=True))
    if "fell" in pair_rows and not any(h.label == "fell" for h in worse):
        worse.extend(_induced_falls(pair_rows))
    return worse


def _induced_falls(pair_rows: pd.DataFrame) -> list[Harm]:
    """A `Harm` when the arm fell in more than INDUCED_FALL_LIMIT of the pairs whose `none` + `stiff`
    run did not fall (a fall it made, however few pairs: the interval alone would let 3 of 7 pass)."""
    ours = pair_rows["fell"].to_numpy(dtype=float)
    reference = pair_rows["fell:reference"].to_numpy(dtype=float)
    survived = reference == 0
    made = int(((ours == 1) & survived).sum())
    if not survived.any() or made <= INDUCED_FALL_LIMIT * survived.sum():
        return []
    evidence = f"made the robot fall in {made} of the {int(survived.sum())} runs none + stiff survives"
    return [Harm(f"made to fall ({made} of {int(survived.sum())})", evidence, interval=False)]


def _same_note(ok: pd.DataFrame, arm: Arm, other: Arm) -> str:
    """ "direction + stiff (4 runs; direction chose no_action in 4/4)": what the merged arm did,
    when its strategy records its choice (a `<strategy>_strategy` column)."""
    runs = paired.arm_runs(ok, other)
    note = f"{paired.name(other)} ({len(runs)} runs"
    column = f"{other[0]}_strategy"
    if other[0] != arm[0] and column in runs and runs[column].notna().any():
        choice = runs[column].fillna("nothing").value_counts()
        note += f"; {other[0]} chose {choice.index[0]} in {int(choice.iloc[0])}/{len(runs)}"
    return note + ")"


def arm_order(runs: pd.DataFrame, done: Ranked | None = None) -> list[Arm]:
    """The (strategy, policy) pairs naming the ranking's rows, best first."""
    table = (done or ranked(runs)).table
    return list(zip(table.pre_impact, table.policy)) if len(table) else []


def shown_table(done: Ranked) -> pd.DataFrame:
    """The ranking as pages show it: each row named as everywhere else ("none + stiff = direction
    + stiff", "onnx (learned)") in place of its strategy and policy columns."""
    if done.table.empty:
        return done.table
    names = [row_name(done, arm) for arm in zip(done.table.pre_impact, done.table.policy)]
    return done.table.drop(columns=["pre_impact", "policy"]).assign(arm=names).set_index("arm").reset_index()


def row_name(done: Ranked, arm: Arm) -> str:
    """The row's arm and the arms merged into it: "none + stiff = direction + stiff"."""
    return " = ".join(paired.name(a) for a in [arm, *done.same.get(arm, [])])


def best_arms(done: Ranked) -> list[Arm]:
    """The rows of the best mean rank among those without a `Harm` (clearly worse than `none` +
    `stiff` on a harm measure, or falls made where it survives): one is the verdict's named arm,
    more are a tie."""
    table = done.table
    arms = [a for a in zip(table.pre_impact, table.policy) if not done.harm[a]] if len(table) else []
    rank = dict(zip(zip(table.pre_impact, table.policy), table["mean rank"])) if arms else {}
    return [arm for arm in arms if rank[arm] == rank[arms[0]]]


def verdict(runs: pd.DataFrame, done: Ranked | None = None) -> str:
    """One line that follows from the ranking beside it (docs/report.md, "The verdict"): the arm of
    the best mean rank among those without a `Harm` against `none` + `stiff`, and the measures on
    which it is clearly better than the runner-up; a tie is called a tie."""
    done = done or ranked(runs)
    table = done.table
    if len(table) == 0:
        return "no successful runs"
    arms = list(zip(table.pre_impact, table.policy))
    if len(arms) == 1:
        return f"only {row_name(done, arms[0])} ran"
    eligible = [arm for arm in arms if not done.harm[arm]]
    tied = best_arms(done)
    if not tied:
        return (
            "no arm named: every one is clearly worse than none + stiff on a harm measure or made the"
            " robot fall where it survives"
        )
    rank = dict(zip(arms, table["mean rank"]))
    best = tied[0]
    left_out = _left_out(done, arms[: arms.index(best)])
    if len(tied) > 1:
        names = ", ".join(row_name(done, arm) for arm in tied)
        return f"a tie: {names} share the best mean rank ({rank[best]:g} of {len(arms)}){left_out}"
    runs_of_best = max(e.n for e in done.estimates[best].values())
    runs_text = f"{runs_of_best} run{'s' if runs_of_best != 1 else ''}"
    line = (
        f"least damage: {row_name(done, best)} (mean rank {rank[best]:g} of {len(arms)} over "
        f"{len(done.measures)} measures, {runs_text}){left_out}"
    )
    if not any(paired.REFERENCE in [arm, *done.same.get(arm, [])] for arm in arms):
        line += "; no none + stiff runs here, so harm against it is not checked"
    if runs_of_best < 2:
        return line + "; one run each, so no interval: a ranking of single falls, not of distributions"
    if len(eligible) == 1:
        return line + (
            "; every other arm is clearly worse than none + stiff on fell or vulnerable parts hit, or made"
            " the robot fall where it survives"
        )
    return line + _against_runner_up(done, best, eligible[1])


def _left_out(done: Ranked, above: list[Arm]) -> str:
    """Why the arms ranked above the named one are not named."""
    notes = []
    for arm in above:
        worse = [h.evidence for h in done.harm[arm] if h.interval]
        reasons = [f"is clearly worse than none + stiff on {', '.join(worse)}"] if worse else []
        reasons += [h.evidence for h in done.harm[arm] if not h.interval]
        notes.append(f"{row_name(done, arm)} ranks higher but " + " and ".join(reasons))
    return "".join(f"; {note}" for note in notes)


def _against_runner_up(done: Ranked, best: Arm, runner_up: Arm) -> str:
    """The measures on which the named arm's interval is clear of the runner-up's on the side of
    less damage (and, said too, those on the side of more)."""
    better, worse = [], []
    for m in done.measures:
        ours, theirs = done.estimates[best][m.column], done.estimates[runner_up][m.column]
        if ours.disjoint(theirs):
            less = ours.value < theirs.value if m.lower_is_better else ours.value > theirs.value
            (better if less else worse).append(m.label.split(" (")[0])
    other = row_name(done, runner_up)
    if better:
        line = f"; clearly less damage than the runner-up ({other}) on {', '.join(better)}"
    else:
        line = f"; not clearly better than the runner-up ({other}) on any measure: no clear winner"
    return line + (f"; clearly more on {', '.join(worse)}" if worse else "")
