"""Metric regression against a stored baseline, for CI (`fallbench check`).

A case is one (scenario point, policy, pre-impact strategy). The baseline is a CSV (diffable in
review) of those cases' metrics; tolerances are a versioned YAML file of absolute and relative
bounds per metric. A NaN, a missing case, a new failure or a metric outside its tolerance is a
regression.

In the baseline an empty cell means the metric does not apply to the case (e.g. `landing_error`
without reshaping): the run must not have it either. A cell that is not a finite number (`nan`,
`inf`, text) or a missing column is a corrupt baseline, never a pass: `BaselineError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from ruamel.yaml import YAML

CASE = ["point", "policy", "pre_impact"]
TOLERANCES_VERSION = 1


@dataclass(frozen=True)
class Tolerance:
    abs: float
    rel: float

    def allows(self, baseline: float, now: float) -> bool:
        return abs(now - baseline) <= self.abs + self.rel * abs(baseline)


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


def load_tolerances(path: Path) -> dict[str, Tolerance]:
    doc = YAML(typ="safe").load(path.read_text())
    if not isinstance(doc, dict) or doc.get("version") != TOLERANCES_VERSION:
        raise ValueError(f"{path}: expected `version: {TOLERANCES_VERSION}` and a `metrics` mapping")
    default = doc.get("default", {})
    tolerances = {}
    for metric, spec in (doc.get("metrics") or {}).items():
        spec = {**default, **(spec or {})}
        tolerances[metric] = Tolerance(float(spec.get("abs", 0.0)), float(spec.get("rel", 0.0)))
    return tolerances


class BaselineError(ValueError):
    """A baseline that cannot be trusted; the message names the file, line, case and metric."""


def _number(value: object) -> float:
    """A metric value as float; None (a text metric that did not apply) is NaN."""
    return float("nan") if value is None else float(value)  # type: ignore[arg-type]


def _key(row: pd.Series) -> str:
    return " / ".join(str(row[c]) for c in CASE)


def compare(baseline: pd.DataFrame, now: pd.DataFrame, tolerances: dict[str, Tolerance]) -> list[Regression]:
    current = {_key(row): row for _, row in now.iterrows()}
    found: list[Regression] = []
    for _, base in baseline.iterrows():
        case = _key(base)
        row = current.get(case)
        if row is None:
            found.append(Regression(case, "(run)", "present", "missing", "-"))
            continue
        if base["status"] == "ok" and row["status"] != "ok":
            found.append(Regression(case, "status", "ok", f"{row['status']}: {row['error']}", "-"))
            continue
        for metric, tol in tolerances.items():
            if metric not in base.index:
                continue
            old, new = float(base[metric]), _number(row.get(metric))
            tolerance = f"{tol.abs:g} + {tol.rel:g} x |baseline|"
            if math.isnan(old):  # the metric does not apply to this case: it must not appear now
                if not math.isnan(new):
                    found.append(Regression(case, metric, "n/a", new, tolerance))
                continue
            if math.isnan(new) or not tol.allows(old, new):
                found.append(Regression(case, metric, old, new, tolerance))
    return found


def baseline_frame(results: pd.DataFrame, tolerances: dict[str, Tolerance]) -> pd.DataFrame:
    columns = CASE + ["status", "error"] + [m for m in tolerances if m in results.columns]
    return results[columns].sort_values(CASE).reset_index(drop=True)


def write_baseline(frame: pd.DataFrame, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    frame.to_csv(tmp, index=False, float_format="%.17g")
    tmp.replace(path)


def read_baseline(path: Path, tolerances: dict[str, Tolerance] | None = None) -> pd.DataFrame:
    """The baseline with every checked metric as a float (NaN = does not apply); raises
    BaselineError for a missing column or a cell that is not empty nor a finite number."""
    raw = pd.read_csv(path, dtype=str, keep_default_na=False)
    required = CASE + ["status"] + list(tolerances or [])
    missing = [c for c in required if c not in raw.columns]
    if missing:
        raise BaselineError(
            f"{path}:1: missing column(s) {', '.join(missing)} (rebuild it with `fallbench check --update`)"
        )
    frame = raw.copy()
    for metric in tolerances or [c for c in raw.columns if c not in CASE + ["status", "error"]]:
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
