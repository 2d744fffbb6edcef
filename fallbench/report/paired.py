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


class ArmRuns:
    """A family's successful runs (`ok`) by arm, indexed once: each arm's rows, its first row per
    pair key, and each pair key as one integer. Selecting an arm's rows by comparing label columns,
    then joining them with the reference's on the keys, was most of the report's ranking time."""

    def __init__(self, ok: pd.DataFrame) -> None:
        self.ok = ok
        self.keys = keys_of(ok)
        rows = ok.groupby(["pre_impact", "policy"], sort=False).indices if len(ok) else {}
        self._rows: dict[Arm, np.ndarray] = {(str(s), str(p)): r for (s, p), r in rows.items()}
        first = ~ok.duplicated([*self.keys, "pre_impact", "policy"]).to_numpy() if len(ok) else None
        self._first = {arm: r[first[r]] for arm, r in self._rows.items()}
        keyed = ok.groupby(self.keys, sort=False, dropna=False) if self.keys and len(ok) else None
        self._codes = keyed.ngroup().to_numpy() if keyed is not None else np.zeros(len(ok), dtype=int)
        self._floats: dict[str, np.ndarray] = {}
        self._arrays: dict[str, np.ndarray] = {}

    def values(self, column: str) -> np.ndarray:
        """The column as floats, one per row of `ok`."""
        if column not in self._floats:
            self._floats[column] = self.ok[column].astype(float).to_numpy()
        return self._floats[column]

    def all_rows(self, arm: Arm) -> np.ndarray:
        """Positions in `ok` of every run of the arm, in order."""
        return self._rows.get(arm, np.zeros(0, dtype=int))

    def first_rows(self, arm: Arm) -> np.ndarray:
        """Positions in `ok` of the arm's first run per pair key, in order."""
        return self._first.get(arm, np.zeros(0, dtype=int))

    def runs(self, arm: Arm, columns: Sequence[str] | None = None) -> pd.DataFrame:
        """The arm's runs, one per pair key (the keys and `columns` only, if given)."""
        chosen = self.ok.iloc[self.first_rows(arm)]
        return chosen if columns is None else chosen[self.keys + list(columns)]

    def pair_rows(self, arm: Arm, reference: Arm = REFERENCE) -> tuple[np.ndarray, np.ndarray]:
        """Positions in `ok` of the arm's runs that have a `reference` run on the same pair key,
        in order, and of those reference runs."""
        mine, theirs = self.first_rows(arm), self.first_rows(reference)
        by_key = np.full(int(self._codes.max(initial=-1)) + 1, -1)
        by_key[self._codes[theirs]] = theirs
        matched = by_key[self._codes[mine]]
        return mine[matched >= 0], matched[matched >= 0]

    def pairs(self, arm: Arm, columns: Sequence[str]) -> pd.DataFrame:
        """The arm's runs joined with their reference run (`<column>:reference`); runs without one
        are left out."""
        mine, theirs = self.pair_rows(arm)
        joined = {c: self._array(c)[mine] for c in [*self.keys, *columns]}
        return pd.DataFrame(joined | {f"{c}:reference": self._array(c)[theirs] for c in columns})

    def _array(self, column: str) -> np.ndarray:
        if column not in self._arrays:
            self._arrays[column] = self.ok[column].to_numpy()
        return self._arrays[column]

    def identical_groups(self, arms: Sequence[Arm], columns: Sequence[str]) -> list[list[Arm]]:
        """The arms in groups whose runs have the same pair keys and the same value on every column,
        pair by pair (e.g. a strategy that never acted and the same policy without it); each group in
        the order of `arms`, its first arm the one that names it."""

        def falls(arm: Arm) -> tuple[np.ndarray, np.ndarray]:
            rows = self.first_rows(arm)
            rows = rows[np.argsort(self._codes[rows], kind="stable")]
            return self._codes[rows], np.array([self.values(c)[rows] for c in columns])

        def same(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
            return np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1], equal_nan=True)

        seen = {arm: falls(arm) for arm in arms}
        groups: list[list[Arm]] = []
        for arm in arms:
            group = next((g for g in groups if same(seen[g[0]], seen[arm])), None)
            if group is None:
                groups.append([arm])
            else:
                group.append(arm)
        return groups


def arm_runs(ok: pd.DataFrame, arm: Arm, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """The arm's successful runs, one per pair key (only the keys and `columns`, if given)."""
    return ArmRuns(ok).runs(arm, columns)


def pairs(ok: pd.DataFrame, arm: Arm, columns: Sequence[str]) -> pd.DataFrame:
    """The arm's runs joined with their reference run (`<column>:reference`); runs without one are
    left out (`ArmRuns.pairs`)."""
    return ArmRuns(ok).pairs(arm, columns)


def change(pair_rows: pd.DataFrame, column: str) -> np.ndarray:
    """The arm's value minus its reference's, per pair (NaN where either is missing)."""
    ours = pair_rows[column].to_numpy(dtype=float)
    return ours - pair_rows[f"{column}:reference"].to_numpy(dtype=float)


def identical_groups(ok: pd.DataFrame, arms: Sequence[Arm], columns: Sequence[str]) -> list[list[Arm]]:
    """`ArmRuns.identical_groups`."""
    return ArmRuns(ok).identical_groups(arms, columns)


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
