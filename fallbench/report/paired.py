"""Runs paired with the unprotected fall: each run of an arm (pre-impact strategy, gain policy) with
the `none` + `stiff` run of the same robot, scenario, point and seed. From the pairs: which arms
fell the same way as another in every pair (one row of the ranking), which are clearly worse than
the reference on a harm measure (never named a winner), and each arm's probability of improvement
(rliable's practice: the share of pairs in which it does less damage, ties counting half)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from fallbench.report.names import arm_name
from fallbench.report.stats import Estimate, bootstrap

Arm = tuple[str, str]  # (pre-impact strategy, gain policy)


@dataclass(frozen=True)
class Measure:
    """A damage measure of the ranking: its column, label, direction and statistics."""

    column: str
    label: str
    lower_is_better: bool = True
    statistic: str = "median"  # "mean" for booleans: the fraction of runs
    change: str = "median"  # of paired changes; "mean" for booleans and counts (their median is mostly 0)


PAIR_KEYS = ("robot", "scenario", "point", "seed")
REFERENCE: Arm = ("none", "stiff")  # the unprotected fall the learning literature compares against
HARM_MEASURES = ("fell", "vulnerable_hits")  # an arm clearly worse on one of these is never a winner


def name(arm: Arm) -> str:
    return arm_name(*arm)


def keys_of(runs: pd.DataFrame) -> list[str]:
    return [k for k in PAIR_KEYS if k in runs]


LABELS = ("robot", "scenario", "point", "pre_impact", "policy", "status")  # what rows are selected by


def narrow(runs: pd.DataFrame, measures: Sequence[Measure]) -> pd.DataFrame:
    """Only the columns pairing and ranking read (pair keys, strategy, policy, status, the measures
    and each strategy's recorded choice), the labels as Python strings: a store has hundreds of
    columns, every row selection copies them all, and Arrow-backed strings are the slowest."""
    wanted = [*keys_of(runs), "pre_impact", "policy", "status", *(m.column for m in measures)]
    wanted += [c for c in runs.columns if c.endswith("_strategy")]
    kept = runs[list(dict.fromkeys(c for c in wanted if c in runs))]
    return kept.astype({c: object for c in LABELS if c in kept})


def arm_runs(ok: pd.DataFrame, arm: Arm, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """The arm's successful runs, one per pair key (only the keys and `columns`, if given: a store
    has hundreds of columns, and copying them all made pairing the report's slowest table)."""
    keys = keys_of(ok)
    mine = (ok.pre_impact == arm[0]) & (ok.policy == arm[1])
    return (ok.loc[mine] if columns is None else ok.loc[mine, keys + list(columns)]).drop_duplicates(keys)


def pairs(
    ok: pd.DataFrame, arm: Arm, columns: Sequence[str], reference: pd.DataFrame | None = None
) -> pd.DataFrame:
    """The arm's runs joined with their reference run (`<column>:reference`); runs without one are
    left out. `reference`: `arm_runs(ok, REFERENCE, columns)`, if already selected."""
    reference = arm_runs(ok, REFERENCE, columns) if reference is None else reference
    return arm_runs(ok, arm, columns).merge(reference, on=keys_of(ok), suffixes=("", ":reference"))


def change(pair_rows: pd.DataFrame, column: str) -> np.ndarray:
    """The arm's value minus its reference's, per pair (NaN where either is missing)."""
    ours = pair_rows[column].to_numpy(dtype=float)
    return ours - pair_rows[f"{column}:reference"].to_numpy(dtype=float)


def identical_groups(ok: pd.DataFrame, arms: Sequence[Arm], columns: Sequence[str]) -> list[list[Arm]]:
    """The arms in groups whose runs have the same pair keys and the same value on every column,
    pair by pair (e.g. a strategy that never acted and the same policy without it); each group in
    the order of `arms`, its first arm the one that names it."""
    keys = keys_of(ok)
    runs = {
        arm: arm_runs(ok, arm, columns)
        .astype({c: float for c in columns})
        .sort_values(keys)
        .reset_index(drop=True)
        for arm in arms
    }
    groups: list[list[Arm]] = []
    for arm in arms:
        same = next((g for g in groups if runs[g[0]].equals(runs[arm])), None)
        if same is None:
            groups.append([arm])
        else:
            same.append(arm)
    return groups


def clearly_worse(estimate: Estimate, lower_is_better: bool = True) -> bool:
    """Whether a paired change shows the arm clearly worse than its reference: the 95 % interval
    on the side of more damage; with a single pair (no interval), its one change on that side."""
    sign = 1.0 if lower_is_better else -1.0
    if estimate.n == 1:
        return bool(sign * estimate.value > 0)
    return bool(min(sign * estimate.low, sign * estimate.high) > 0)


def clearly_better(estimate: Estimate, lower_is_better: bool = True) -> bool:
    return clearly_worse(
        Estimate(-estimate.value, -estimate.high, -estimate.low, estimate.n), lower_is_better
    )


def improvement_scores(pair_rows: pd.DataFrame, measures: Sequence[Measure]) -> np.ndarray:
    """Per pair: the mean over the measures of 1 where the arm does less damage than its
    reference (lower, or higher where higher is better), 0.5 where equal, 0 where more; measures
    missing in either run are left out of the mean."""
    scores = []
    for measure in measures:
        delta = change(pair_rows, measure.column) * (1.0 if measure.lower_is_better else -1.0)
        scores.append(
            np.where(np.isnan(delta), np.nan, np.where(delta < 0, 1.0, np.where(delta == 0, 0.5, 0.0)))
        )
    if not scores:
        return np.array([])
    stacked = np.vstack(scores)
    counted = (~np.isnan(stacked)).sum(axis=0)
    return np.where(counted > 0, np.nansum(stacked, axis=0) / np.maximum(counted, 1), np.nan)


def probability_of_improvement(ok: pd.DataFrame, arm: Arm, measures: Sequence[Measure]) -> Estimate:
    """The mean of the arm's improvement scores over its pairs, with its bootstrap interval
    (0.5: as often better as worse than `none` + `stiff`)."""
    pair_rows = pairs(ok, arm, [m.column for m in measures])
    return bootstrap(improvement_scores(pair_rows, measures), "mean")
