"""`fallbench converge`: the same falls at `physics_dt`, /2, /4, ..., and how much each headline
metric moves with the last halving; with `--end`, the same falls given twice their cap and twice
their rest hold, and whether any metric moves.

A benchmark's numbers must be properties of the fall and the controller, not of the integrator's
step: a metric is converged when halving the step changes it by at most `TOLERANCE` (relative, with
a floor per metric so that values near zero are judged on an absolute scale). Nor of when the run
stops: a run that came to rest gives the same bits with twice the cap (`end_table`), and its
headline metrics move by at most `TOLERANCE` when it must stay at rest twice as long. The runs are
ordinary runs of the store (the point's label gains `physics_dt=...`, `duration=...` or
`rest.hold=...`), so the report sees them too.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import pandas as pd

from fallbench.analysis.metrics import HEADLINE_METRICS
from fallbench.results.runner import RunSpec, identity
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


WALL_CLOCK = re.compile(r"_ms(_|$)|^wall_time_s$")  # wall-clock figures differ from run to run by nature


@dataclass(frozen=True)
class Ladder:
    """One point at each rung: for the step, `levels[i]` runs at `physics_dt / 2**i`; for the end,
    at its cap, twice its cap and twice its rest hold. `names` label the rungs."""

    base: ScenarioPoint
    levels: list[ScenarioPoint]
    names: list[str]


def _rung(point: ScenarioPoint, key: str, value: float) -> ScenarioPoint:
    """The point with the dotted scenario key set to `value`; ScenarioError if that breaks the
    scenario's own rules (control_dt not a multiple of the step, over the step budget)."""
    data = point.scenario.model_dump()
    section, _, field = key.rpartition(".")
    (data[section] if section else data)[field] = value
    try:
        scenario = Scenario.model_validate(data)
    except ValueError as exc:
        reason = str(exc).splitlines()[-1].strip()
        raise ScenarioError(point.source, None, key, f"{value:g} s: {reason}") from None
    return ScenarioPoint(scenario, {**point.swept, key: value}, point.source, point.randomized)


def ladder(point: ScenarioPoint, levels: int) -> Ladder:
    """The point at its `physics_dt` and `levels - 1` halvings of it."""
    steps = [point.scenario.physics_dt / 2**level for level in range(levels)]
    return Ladder(
        point, [_rung(point, "physics_dt", dt) for dt in steps], [f"{dt * 1e3:g} ms" for dt in steps]
    )


def end_ladder(point: ScenarioPoint) -> Ladder:
    """The point as it is, with twice its cap (`duration`), and with twice its rest hold."""
    cap, hold = point.scenario.duration, point.scenario.rest.hold
    rungs = [point, _rung(point, "duration", 2 * cap), _rung(point, "rest.hold", 2 * hold)]
    return Ladder(point, rungs, [f"cap {cap:g} s", f"cap {2 * cap:g} s", f"hold {2 * hold:g} s"])


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
                row.update(dict(zip(item.names, values)))
                row.update({"last change": change, "converged": change <= TOLERANCE})
                rows.append(row)
    return pd.DataFrame(rows)


def _same(a: object, b: object) -> bool:
    """Bit-identical, NaN equal to NaN."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))


def end_table(ladders: list[Ladder], runs: pd.DataFrame, specs: list[RunSpec]) -> pd.DataFrame:
    """One row per (point, pre-impact, policy): whether it settled and when (s), the measures that
    differ at all with twice the cap (`cap_changed`: must be none for a settled run), and the
    headline measure that moves most with twice the rest hold (`hold_change`, relative, as
    `relative_change`). `ok`: a settled run whose bits the cap left alone and whose headline
    measures the longer hold moved by at most TOLERANCE."""
    by_id = runs[runs["status"] == "ok"].set_index("run_id")
    # not measures of the fall: who the run is (the runner's identity columns, each rung's own swept
    # `param:` columns), its status, and wall-clock figures
    who = set(identity(specs[0])) | {"status", "error"} if specs else set()
    measures = [c for c in by_id.columns if c not in who and not c.startswith(("param:", "version:"))]
    measures = [c for c in measures if not WALL_CLOCK.search(c)]
    rows = []
    for item in ladders:
        for pre_impact, policy in sorted({(s.pre_impact, s.policy) for s in specs if s.point in item.levels}):
            ids = [RunSpec(rung, policy, pre_impact).run_id for rung in item.levels]
            if not all(run_id in by_id.index for run_id in ids):
                continue
            base, capped, held = (by_id.loc[run_id] for run_id in ids)
            changed = [c for c in measures if not _same(base[c], capped[c])]
            moves = {
                m: relative_change(float(base[m]), float(held[m]), m)
                for m in HEADLINE_METRICS
                if m in measures
            }
            worst = max(moves, key=lambda m: moves[m]) if moves else ""
            settled = bool(base.get("settled", False))
            rows.append(
                {
                    "point": item.base.label,
                    "pre_impact": pre_impact,
                    "policy": policy,
                    "settled": settled,
                    "time_to_rest": float(base.get("time_to_rest", math.nan)),
                    "cap_changed": ",".join(changed),
                    "hold_change": moves.get(worst, 0.0),
                    "hold_worst": worst,
                    "ok": settled and not changed and moves.get(worst, 0.0) <= TOLERANCE,
                }
            )
    return pd.DataFrame(rows)
