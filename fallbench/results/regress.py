"""Metric regression against a stored baseline, for CI (`fallbench check`).

A case is one (scenario point, policy, pre-impact strategy); a group is a case over the suite's
seeds (the point without its `#sN`). The baseline is a CSV (diffable in review) of every case's
metrics; tolerances are a versioned YAML file with two kinds of metric:

- `per_run` metrics are deterministic functions of the landing (landing window, pre-impact, impact
  time and speed): each case must stay within `abs + rel * |baseline|` of its baseline.
- `distribution` metrics are whole-episode measures after a fall, where a change in the last digit
  of one number can move a case's value by a factor of ten: each group's statistic over its seeds
  (median, or mean for a rate) must stay within `abs + rel * |baseline| + noise`, where `noise` is
  the `confidence` quantile of |statistic(B1) - statistic(B2)| for B1, B2 bootstrap resamples of
  the baseline group (seeded, so a check is reproducible): how far two draws of the same spread
  land apart with this many seeds.

A NaN, a missing case, a new failure or a metric outside its tolerance is a regression. In the
baseline an empty cell means the metric does not apply to the case (e.g. `landing_error` without
reshaping): the run must not have it either. A cell that is not a finite number (`nan`, `inf`,
text) or a missing column is a corrupt baseline, never a pass: `BaselineError`. Columns
`version:<package>` record the software the baseline was made with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from ruamel.yaml import YAML

CASE = ["point", "policy", "pre_impact"]
GROUP = "group"  # the point without its seed and the values drawn from it (ScenarioPoint.group)
TOLERANCES_VERSION = 2
VERSION_PREFIX = "version:"
UNVERSIONED = {"version:code", "version:fallbench"}  # ours: what the check is there to judge
STATISTICS = {"median": np.median, "mean": np.mean}


@dataclass(frozen=True)
class Tolerance:
    abs: float
    rel: float
    statistic: str = "median"  # of a distribution metric over a group's seeds

    def allowance(self, baseline: float, noise: float = 0.0) -> float:
        return self.abs + self.rel * abs(baseline) + noise

    def allows(self, baseline: float, now: float, noise: float = 0.0) -> bool:
        return abs(now - baseline) <= self.allowance(baseline, noise)

    def describe(self, noise: float | None = None) -> str:
        text = f"{self.abs:g} + {self.rel:g} x |baseline|"
        return text if noise is None else f"{text} + noise {noise:.3g}"


@dataclass(frozen=True)
class Tolerances:
    per_run: dict[str, Tolerance]
    distribution: dict[str, Tolerance]
    confidence: float = 0.99
    resamples: int = 2000
    seed: int = field(default=0)

    @property
    def metrics(self) -> list[str]:
        return [*self.per_run, *self.distribution]


@dataclass(frozen=True)
class Regression:
    case: str
    metric: str
    baseline: object
    now: object
    tolerance: str

    @property
    def change(self) -> str:
        if (
            isinstance(self.baseline, float)
            and isinstance(self.now, float)
            and math.isfinite(self.baseline)
            and math.isfinite(self.now)
        ):
            return f"{self.now - self.baseline:+.4g}"
        return ""


def load_tolerances(path: Path) -> Tolerances:
    doc = YAML(typ="safe").load(path.read_text())
    if not isinstance(doc, dict) or doc.get("version") != TOLERANCES_VERSION:
        raise ValueError(
            f"{path}: expected `version: {TOLERANCES_VERSION}` with `per_run` and `distribution` sections"
        )
    default = doc.get("default", {})
    sections = {}
    for kind in ("per_run", "distribution"):
        section = doc.get(kind) or {}
        sections[kind] = {}
        for metric, spec in (section.get("metrics") or {}).items():
            spec = {**default, **(spec or {})}
            statistic = str(spec.get("statistic", "median"))
            if statistic not in STATISTICS:
                raise ValueError(
                    f"{path}: {kind}.{metric}.statistic: {statistic!r} is not one of {list(STATISTICS)}"
                )
            sections[kind][metric] = Tolerance(
                float(spec.get("abs", 0.0)), float(spec.get("rel", 0.0)), statistic
            )
    spread = doc.get("distribution") or {}
    return Tolerances(
        per_run=sections["per_run"],
        distribution=sections["distribution"],
        confidence=float(spread.get("confidence", 0.99)),
        resamples=int(spread.get("resamples", 2000)),
        seed=int(spread.get("seed", 0)),
    )


class BaselineError(ValueError):
    """A baseline that cannot be trusted; the message names the file, line, case and metric."""


def _number(value: object) -> float:
    """A metric value as float; None (a text metric that did not apply) is NaN."""
    return float("nan") if value is None else float(value)  # type: ignore[arg-type]


def _key(row: pd.Series) -> str:
    return " / ".join(str(row[c]) for c in CASE)


def compare(baseline: pd.DataFrame, now: pd.DataFrame, tolerances: Tolerances) -> list[Regression]:
    """Every regression of `now` against `baseline`: per case, then per group of seeds."""
    found, compared = _compare_cases(baseline, now, tolerances.per_run)
    keyed = now.assign(_key=[_key(row) for _, row in now.iterrows()])
    return found + _compare_groups(baseline, keyed[keyed["_key"].isin(compared)], tolerances)


def _compare_cases(
    baseline: pd.DataFrame, now: pd.DataFrame, tolerances: dict[str, Tolerance]
) -> tuple[list[Regression], set[str]]:
    """Regressions of single runs (missing, newly failed, per-run metric out of tolerance), and the
    cases that ran fine in both, whose distribution metrics are then compared."""
    current = {_key(row): row for _, row in now.iterrows()}
    found: list[Regression] = []
    compared = set()
    for _, base in baseline.iterrows():
        case = _key(base)
        row = current.get(case)
        if row is None:
            found.append(Regression(case, "(run)", "present", "missing", "-"))
            continue
        if base["status"] == "ok" and row["status"] != "ok":
            found.append(Regression(case, "status", "ok", f"{row['status']}: {row['error']}", "-"))
            continue
        compared.add(case)
        for metric, tolerance in tolerances.items():
            old, new = float(base[metric]), _number(row.get(metric))
            if _applies_differently(old, new) or (not math.isnan(old) and not tolerance.allows(old, new)):
                found.append(
                    Regression(case, metric, "n/a" if math.isnan(old) else old, new, tolerance.describe())
                )
    return found, compared


def _applies_differently(old: float, new: float) -> bool:
    return math.isnan(old) != math.isnan(new)


def _compare_groups(baseline: pd.DataFrame, now: pd.DataFrame, tolerances: Tolerances) -> list[Regression]:
    """Distribution metrics: one statistic per group over the cases both runs have."""
    found: list[Regression] = []
    rng = np.random.default_rng(tolerances.seed)
    keyed = baseline.assign(_key=[_key(row) for _, row in baseline.iterrows()])
    base_groups = dict(tuple(keyed.groupby(_group_key(keyed))))
    for group, rows in now.groupby(_group_key(now)):
        base = base_groups[group].set_index("_key").loc[rows["_key"]]
        label = f"{group[0]} / {group[1]} / {group[2]} ({len(rows)} seeds)"
        for metric, tolerance in tolerances.distribution.items():
            old, new = base[metric].astype(float).to_numpy(), rows[metric].map(_number).to_numpy()
            if (np.isnan(old) != np.isnan(new)).any():
                found.append(Regression(label, metric, "n/a on some seeds", "applies", tolerance.describe()))
                continue
            old, new = old[~np.isnan(old)], new[~np.isnan(new)]
            if len(old) == 0:
                continue
            statistic = STATISTICS[tolerance.statistic]
            noise = _bootstrap_noise(old, statistic, tolerances, rng)
            expected, observed = float(statistic(old)), float(statistic(new))
            if not tolerance.allows(expected, observed, noise):
                found.append(
                    Regression(
                        label,
                        f"{metric} ({tolerance.statistic})",
                        expected,
                        observed,
                        tolerance.describe(noise),
                    )
                )
    return found


def _group_key(frame: pd.DataFrame) -> list[pd.Series]:
    """(scenario point over its seeds, policy, pre-impact): the cases a distribution metric pools."""
    return [frame[GROUP], frame["policy"], frame["pre_impact"]]


def _bootstrap_noise(
    values: np.ndarray, statistic, tolerances: Tolerances, rng: np.random.Generator
) -> float:
    """The `confidence` quantile of |statistic(B1) - statistic(B2)| over bootstrap resamples B1, B2
    of `values`: how far two samples of this spread and size land apart by chance."""
    draws = rng.choice(values, size=(2, tolerances.resamples, len(values)))
    spread = np.abs(statistic(draws[0], axis=1) - statistic(draws[1], axis=1))
    return float(np.quantile(spread, tolerances.confidence))


def baseline_frame(results: pd.DataFrame, tolerances: Tolerances) -> pd.DataFrame:
    """The baseline's rows: the cases, their metrics and the versions of what decides the numbers."""
    versions = sorted(c for c in results.columns if c.startswith(VERSION_PREFIX) and c not in UNVERSIONED)
    columns = (
        CASE + [GROUP, "status", "error"] + [m for m in tolerances.metrics if m in results.columns] + versions
    )
    return results[columns].sort_values(CASE).reset_index(drop=True)


def changed_versions(baseline: pd.DataFrame, now: pd.DataFrame) -> list[str]:
    """`package baseline -> now` for every recorded package whose version differs."""
    changes = []
    for column in sorted(c for c in baseline.columns if c.startswith(VERSION_PREFIX)):
        old = sorted(set(baseline[column].astype(str)))
        new = sorted(set(now[column].astype(str))) if column in now.columns else ["(not recorded)"]
        if old != new:
            changes.append(f"{column.removeprefix(VERSION_PREFIX)} {', '.join(old)} -> {', '.join(new)}")
    return changes


def write_baseline(frame: pd.DataFrame, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    frame.to_csv(tmp, index=False, float_format="%.17g")
    tmp.replace(path)


def read_baseline(path: Path, tolerances: Tolerances | None = None) -> pd.DataFrame:
    """The baseline with every checked metric as a float (NaN = does not apply); raises
    BaselineError for a missing column or a cell that is not empty nor a finite number."""
    raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    metrics = (
        tolerances.metrics
        if tolerances
        else [
            c
            for c in raw.columns
            if c not in CASE + [GROUP, "status", "error"] and not c.startswith(VERSION_PREFIX)
        ]
    )
    required = CASE + [GROUP, "status"] + metrics
    missing = [c for c in required if c not in raw.columns]
    if missing:
        raise BaselineError(
            f"{path}:1: missing column(s) {', '.join(missing)} (rebuild it with `fallbench check --update`)"
        )
    frame = raw.copy()
    for metric in metrics:
        frame[metric] = [
            _baseline_cell(path, line, raw.iloc[line - 2], metric) for line in range(2, len(raw) + 2)
        ]
    return frame.astype({"error": str}) if "error" in frame.columns else frame


def _baseline_cell(path: Path, line: int, row: pd.Series, metric: str) -> float:
    text = row[metric].strip()
    if text == "":
        return float("nan")
    value = {"True": 1.0, "False": 0.0}.get(text)
    if value is None:
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
    if not math.isfinite(value):
        raise BaselineError(
            f"{path}:{line}: {_key(row)}: {metric}: {text!r} is not a finite number "
            "(leave the cell empty if the metric does not apply to this case)"
        )
    return value
