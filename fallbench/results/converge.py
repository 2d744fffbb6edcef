"""`fallbench converge`: the same falls at `physics_dt`, /2, /4, ..., and how much each headline
metric moves with the last halving.

A benchmark's numbers must be properties of the fall and the controller, not of the integrator's
step: a metric is converged when halving the step changes it by at most `TOLERANCE` (relative, with
a floor per metric so that values near zero are judged on an absolute scale). The runs are
ordinary runs of the store (the point's label gains `physics_dt=...`), so the report sees them too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd

from fallbench.analysis.metrics import HEADLINE_METRICS
from fallbench.results.runner import RunSpec
from fallbench.scenario import Scenario, ScenarioError, ScenarioPoint

TOLERANCE = 0.05  # relative change of the last halving
# Below these magnitudes a change is judged against the floor instead (metric units): a knee margin
# of 0.001 rad that becomes 0.002 rad has not "changed by 100 %".
FLOORS = {
    "imu_peak_z_landing": 1.0,  # m/s^2
    "contact_force_peak_head": 10.0,  # N
    "contact_force_peak_torso": 10.0,  # N
    "knee_limit_margin": 0.02,  # rad
    "joint_limit_hits": 1.0,  # count
    "fell": 1.0,  # fraction
    "takeover_delay": 0.001,  # s
}


@dataclass(frozen=True)
class Ladder:
    """One point at each step: `levels[i]` runs at `physics_dt / 2**i`."""

    base: ScenarioPoint
    levels: list[ScenarioPoint]

    @property
    def steps(self) -> list[float]:
        return [p.scenario.physics_dt for p in self.levels]


def ladder(point: ScenarioPoint, levels: int) -> Ladder:
    """The point at its `physics_dt` and `levels - 1` halvings of it; raises ScenarioError when a
    step breaks the scenario's own rules (control_dt not a multiple, over the step budget)."""
    rungs = []
    for level in range(levels):
        physics_dt = point.scenario.physics_dt / 2**level
        try:
            scenario = Scenario.model_validate(point.scenario.model_dump() | {"physics_dt": physics_dt})
        except ValueError as exc:
            reason = str(exc).splitlines()[-1].strip()
            raise ScenarioError(point.source, None, "physics_dt", f"{physics_dt:g} s: {reason}") from None
        swept = {**point.swept, "physics_dt": physics_dt}
        rungs.append(ScenarioPoint(scenario, swept, point.source, point.randomized))
    return Ladder(point, rungs)


def relative_change(old: float, new: float, metric: str) -> float:
    """|new - old| / max(|old|, floor): the last halving's change as a fraction."""
    if math.isnan(old) and math.isnan(new):
        return 0.0
    return abs(new - old) / max(abs(old), FLOORS.get(metric, 0.0), 1e-12)


def convergence_table(
    ladders: list[Ladder],
    runs: pd.DataFrame,
    specs: list[RunSpec],
    metrics: tuple[str, ...] = HEADLINE_METRICS,
) -> pd.DataFrame:
    """One row per (point, pre-impact, policy, metric): the value at each step (columns named by the
    step in ms), the last halving's relative change and whether it is within TOLERANCE. Runs are
    found by run id: a rung at the default step is the same run as the plain point's."""
    by_id = runs[runs["status"] == "ok"].set_index("run_id")
    rows = []
    for item in ladders:
        for pre_impact, policy in sorted({(s.pre_impact, s.policy) for s in specs if s.point in item.levels}):
            ids = [RunSpec(rung, policy, pre_impact).run_id for rung in item.levels]
            for metric in metrics:
                if metric not in by_id.columns:
                    continue
                values = [float(by_id[metric].get(run_id, math.nan)) for run_id in ids]
                change = relative_change(values[-2], values[-1], metric)
                row = {"point": item.base.label, "pre_impact": pre_impact, "policy": policy, "metric": metric}
                row.update({f"{dt * 1e3:g} ms": value for dt, value in zip(item.steps, values)})
                row.update({"last change": change, "converged": change <= TOLERANCE})
                rows.append(row)
    return pd.DataFrame(rows)
