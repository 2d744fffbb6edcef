"""Numerical validity: how much the answer moves when the physics step is halved.

The main job runs the 002 drops at the default step and at half of it (scenarios/drop.yaml sweeps
`physics_dt`). Runs at a step other than the default feed only this section, never the rankings:
each headline metric's change with the halving. Each claim's verdict at both steps is
papers/claims.py's `robust_claims`: a claim is robust only if its verdict is the same at both.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fallbench.analysis.metrics import HEADLINE_METRICS
from fallbench.results.converge import relative_change
from fallbench.scenario import DEFAULT_PHYSICS_DT

STEP = "physics_dt"  # s, every run's step (a column of the store)
DEFAULT_STEP = DEFAULT_PHYSICS_DT
SAME_POINT = ["robot", "base_point", "policy", "pre_impact"]


def split_steps(runs: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(runs at the default step, runs at other steps); runs stored without a step are at the default."""
    if STEP not in runs:
        return runs, runs.iloc[0:0]
    other = ~np.isclose(runs[STEP].astype(float).fillna(DEFAULT_STEP), DEFAULT_STEP)
    return runs[~other], runs[other]


def _base_point(points: pd.Series) -> pd.Series:
    """The point's label without its `physics_dt=...`: the same fall at another step."""
    stripped = points.str.replace(r",?physics_dt=[^,\]]+", "", regex=True).str.replace("[,", "[", regex=False)
    return stripped.str.replace("[]", "", regex=False)


def _paired(default: pd.DataFrame, halved: pd.DataFrame) -> pd.DataFrame:
    """One row per fall run at both steps: `<metric>_default` and `<metric>_halved` columns."""
    frames = []
    for runs in (default, halved):
        ok = runs[runs.status == "ok"]
        frames.append(ok.assign(base_point=_base_point(ok.point.astype(str))))
    metrics = [m for m in HEADLINE_METRICS if m in frames[0] and m in frames[1]]
    return frames[0][SAME_POINT + metrics].merge(
        frames[1][SAME_POINT + metrics], on=SAME_POINT, suffixes=("_default", "_halved")
    )


def step_changes(default: pd.DataFrame, halved: pd.DataFrame) -> pd.DataFrame:
    """Per headline metric: the median and worst relative change of the halving over the paired runs
    (`fallbench converge`'s measure: values near zero are judged against a floor, e.g. 10 N)."""
    pairs = _paired(default, halved)
    rows = []
    for metric in (m for m in HEADLINE_METRICS if f"{m}_default" in pairs):
        old, new = pairs[f"{metric}_default"].astype(float), pairs[f"{metric}_halved"].astype(float)
        change = pd.Series([relative_change(a, b, metric) for a, b in zip(old, new)], dtype=float)
        rows.append(
            {
                "metric": metric,
                "runs": len(pairs),
                "median change (%)": round(100 * float(change.median()), 1),
                "worst change (%)": round(100 * float(change.max()), 1),
            }
        )
    return pd.DataFrame(rows)
