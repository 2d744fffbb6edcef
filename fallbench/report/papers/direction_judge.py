"""Judging 004 where steering can matter: the robot's steering authority measured
in free space, the deflection each `none` hit needs, and 004's first claim over the hits whose need
is within that authority.

Authority: the runs in free space (`selection.free_space`: objects never within reach, as in
`scenarios/direction_authority.yaml`), one push per (robot, force, direction), with every candidate of 004 forced in turn (No Action, Lift a Leg left
and right, Take a Step to fixed targets). A candidate's deflection is its actual fall direction
(deg, control trigger to touchdown) minus `none`'s on the same push, wrapped to (-180, 180]; the
authority of a push is the span [min, max] of the deflections of the candidates that fell (runs
that stayed up give no direction and are counted apart). The same span read at the first impact
(`impact_fall_direction_deg`) leaves out where a body that landed on its hands rolled on to: a
sideways fall props on its arms and rolls up to 30 deg further before its CoM is down.

Need: `needed_deflection_deg` of the `none` run (`fallbench.analysis.obstacles`): the smallest rotation of its actual
fall direction into a safe region of its own layout (0 inside one). Both come from runs that do
not involve `direction`'s choices, so neither is tuned toward `direction`'s outcome. A hit is
within authority when its need lies in the span of the nearest measured push (same robot; nearest
push direction, then nearest force).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd
from ruamel.yaml import YAML

from fallbench.report.selection import free_space
from fallbench.results import store

CELL = ["robot", "force", "push_direction"]


def _turn_deg(a: float, b: float) -> float:
    """Smallest rotation (deg, + counter-clockwise) from direction a to direction b, in (-180, 180]."""
    turn = (b - a) % 360.0
    return turn - 360.0 if turn > 180.0 else turn


def _push(results: Path, run_id: str) -> tuple[str, float, float]:
    """(robot, push force N, push direction deg in [0, 360)) of a stored run, from its resolved spec."""
    spec = YAML(typ="safe", pure=True).load((store.run_dir(results, run_id) / "spec.yaml").read_text())
    scenario = spec["scenario"]
    push = scenario.get("push") or {}
    return (
        str(scenario.get("robot", "")),
        float(push.get("force", math.nan)),
        float(push.get("direction", 0.0)) % 360.0,
    )


def with_push(runs: pd.DataFrame, results: Path) -> pd.DataFrame:
    """`runs` with robot, force and push_direction columns read from each run's spec (kept if given)."""
    if {"robot", "force", "push_direction"} <= set(runs.columns):
        return runs
    pushes = [_push(results, rid) for rid in runs.run_id]
    frame = runs.copy()
    frame["robot"] = [p[0] for p in pushes]
    frame["force"] = [p[1] for p in pushes]
    frame["push_direction"] = [p[2] for p in pushes]
    return frame


def _candidate(row: pd.Series) -> str:
    """The forced candidate of an authority run: e.g. lift_leg_left, take_step_right 0.45 m at -45 deg."""
    label = str(row.get("direction_strategy") or "")
    length = row.get("param:policy_params.direction.step_length")
    bearing = row.get("param:policy_params.direction.step_bearing")
    if label.startswith("take_step") and length == length and length is not None:
        label += f" {float(length):.2f} m at {float(bearing):+.0f} deg"
    return label


def _kind(candidate: str) -> str:
    return candidate.split(" ")[0].replace("_left", "").replace("_right", "")


def authority_runs(runs: pd.DataFrame, results: Path) -> pd.DataFrame:
    """One row per forced candidate run of the authority suite: its cell, candidate, whether it fell
    (touchdown), and its deflection from `none`'s fall on the same push (deg), read at touchdown and
    at the first impact."""
    suite = runs[free_space(runs) & (runs.status == "ok")]
    if suite.empty or "actual_fall_direction_deg" not in suite:
        return pd.DataFrame()
    suite = with_push(suite, results)
    fallen = (suite.pre_impact == "none") & (suite.actual_fall_end == "touchdown")  # else no direction
    none = suite[fallen].groupby(CELL)
    forced = suite[suite.pre_impact == "direction"].copy()
    forced["candidate"] = forced.apply(_candidate, axis=1)
    forced["fell"] = forced.actual_fall_end == "touchdown"
    forced["none_direction_deg"] = _on_same_push(forced, none.actual_fall_direction_deg.first())
    forced["deflection_deg"] = _turns(
        forced.none_direction_deg, forced.actual_fall_direction_deg, forced.fell
    )
    # stores from before impact_fall_direction_deg existed have no first-impact reading
    if "impact_fall_direction_deg" in suite:
        at_impact = _on_same_push(forced, none.impact_fall_direction_deg.first())
        forced["impact_deflection_deg"] = _turns(at_impact, forced.impact_fall_direction_deg, forced.fell)
    else:
        forced["impact_deflection_deg"] = math.nan
    return forced[
        CELL
        + ["candidate", "fell", "none_direction_deg", "deflection_deg", "impact_deflection_deg"]
        + ["actual_fall_direction_deg"]
    ]


def _on_same_push(forced: pd.DataFrame, none: pd.Series) -> np.ndarray:
    """deg: `none`'s direction (indexed by cell) on each forced run's push; nan where it has none."""
    return np.asarray(forced.set_index(CELL).index.map(lambda k: none.get(k, math.nan)), dtype=float)


def _turns(start: Iterable[float], end: Iterable[float], fell: Iterable[bool]) -> list[float]:
    """deg: the turn from each `start` to its `end` direction, nan where the run did not fall or
    either direction is missing."""
    return [_turn_deg(a, b) if f and a == a and b == b else math.nan for a, b, f in zip(start, end, fell)]


def _span(values: pd.Series) -> str:
    values = values.dropna()
    return f"{values.min():+.0f}..{values.max():+.0f}" if len(values) else "-"


def authority_table(detail: pd.DataFrame) -> pd.DataFrame:
    """Per (robot, force, push direction): `none`'s fall direction and the deflections reached, in
    all and per candidate class (deg), and how many forced runs stayed up."""
    if detail.empty:
        return pd.DataFrame()
    rows = []
    for (robot, force, direction), cell in detail.groupby(CELL):
        kind = cell.candidate.map(_kind)
        fell = cell[cell.fell]
        rows.append(
            {
                "robot": robot,
                "force (N)": force,
                "push direction (deg)": direction,
                "none falls toward (deg)": round(
                    float(cell.none_direction_deg.iloc[0]), 1
                ),  # nan: none stays up
                "min deflection (deg)": round(float(fell.deflection_deg.min()), 1) if len(fell) else math.nan,
                "max deflection (deg)": round(float(fell.deflection_deg.max()), 1) if len(fell) else math.nan,
                "min at impact (deg)": round(float(fell.impact_deflection_deg.min()), 1),
                "max at impact (deg)": round(float(fell.impact_deflection_deg.max()), 1),
                "no_action": _span(cell[kind == "no_action"].deflection_deg),
                "lift_leg": _span(cell[kind == "lift_leg"].deflection_deg),
                "take_step": _span(cell[kind == "take_step"].deflection_deg),
                "forced runs": len(cell),
                "stayed up": int((~cell.fell).sum()),
            }
        )
    return pd.DataFrame(rows)


def _nearest_cell(table: pd.DataFrame, robot: str, force: float, direction: float) -> pd.Series | None:
    """The authority row of the same robot nearest in push direction, then in force."""
    same = table[table.robot == robot]
    if same.empty or not math.isfinite(force):
        return None
    gap = same["push direction (deg)"].map(lambda d: abs(_turn_deg(d, direction)))
    closest = same[gap == gap.min()]
    return closest.loc[(closest["force (N)"] - force).abs().idxmin()]


def judge_hits(pairs: pd.DataFrame, results: Path, table: pd.DataFrame) -> pd.DataFrame:
    """`none`'s hits of `pairs` (the falls judged: the authority suite left out) with their push,
    their need (deg), the authority span of the nearest measured push, and whether the need is
    within it."""
    hits = pairs[pairs.none_hit].copy()
    if hits.empty or table.empty or "need_deg" not in hits:
        return pd.DataFrame()
    hits = with_push(hits.assign(run_id=hits.none_run_id), results)
    cells = [_nearest_cell(table, hit.robot, hit.force, hit.push_direction) for _, hit in hits.iterrows()]
    spans = [
        ("authority", "min deflection (deg)", "max deflection (deg)"),
        ("impact_authority", "min at impact (deg)", "max at impact (deg)"),
    ]
    for prefix, low, high in spans:
        hits[f"{prefix}_min_deg"] = [math.nan if cell is None else cell[low] for cell in cells]
        hits[f"{prefix}_max_deg"] = [math.nan if cell is None else cell[high] for cell in cells]
    hits["within_authority"] = hits.need_deg.between(hits.authority_min_deg, hits.authority_max_deg)
    hits["within_impact_authority"] = hits.need_deg.between(
        hits.impact_authority_min_deg, hits.impact_authority_max_deg
    )
    return hits


VARIANT = ["predictor", "settings"]  # a sweep's `direction` variants are judged apart (papers/direction.py)


def variants(frame: pd.DataFrame) -> pd.DataFrame:
    """`frame` with the variant columns (004's pendulum, no swept settings, where absent)."""
    return frame.assign(predictor=frame.get("predictor", "pendulum"), settings=frame.get("settings", ""))


def without_empty_settings(table: pd.DataFrame) -> pd.DataFrame:
    """`table` without its settings column when nothing was swept."""
    return table.drop(columns="settings") if (table.get("settings", pd.Series("")) == "").all() else table


def _ratio(n: int, m: int) -> str:
    return f"{n}/{m}" + (f" ({100 * n / m:.0f} %)" if m else "")


def _avoided(hits: pd.DataFrame) -> str:
    """n/m (%) of `hits` that `direction` avoided, or '-' without any."""
    return _ratio(int((~hits.direction_hit.astype(bool)).sum()), len(hits)) if len(hits) else "-"


def judged_table(pairs: pd.DataFrame, hits: pd.DataFrame) -> pd.DataFrame:
    """Per scenario: 004's first claim overall and over the hits whose need is within the measured
    authority (N/M), the clear falls kept clear, and the needs of the hits (`pairs`: the falls
    judged, the authority suite left out)."""
    rows = []
    pairs, hits = variants(pairs), variants(hits)
    for (scenario, predictor, settings), group in pairs.groupby(["scenario", *VARIANT]):
        all_hits = group[group.none_hit]
        clear = group[~group.none_hit]
        judged = (
            hits[(hits.scenario == scenario) & (hits.predictor == predictor) & (hits.settings == settings)]
            if len(hits)
            else pd.DataFrame(columns=["within_authority", "within_impact_authority", "direction_hit"])
        )
        within = judged[judged.within_authority.astype(bool)] if len(judged) else judged
        at_impact = judged[judged.within_impact_authority.astype(bool)] if len(judged) else judged
        need = all_hits.need_deg.abs() if "need_deg" in all_hits else pd.Series(dtype=float)
        rows.append(
            {
                "scenario": scenario,
                "predictor": predictor,
                "settings": settings,
                "runs": len(group),
                "none hits": len(all_hits),
                "need 0 deg (model calls none's fall safe)": int((need == 0).sum()),
                "need <= 15 / 15-30 / 30-45 / > 45 deg": " / ".join(
                    str(int(m.sum()))
                    for m in (
                        (need > 0) & (need <= 15),
                        (need > 15) & (need <= 30),
                        (need > 30) & (need <= 45),
                        need > 45,
                    )
                ),
                "hits within authority": len(within),
                "avoided, within authority": _avoided(within),
                "avoided, within authority at first impact": _avoided(at_impact),
                "avoided, all hits": _ratio(int((~all_hits.direction_hit).sum()), len(all_hits)),
                "clear kept clear": _ratio(int((~clear.direction_hit).sum()), len(clear)),
            }
        )
    return without_empty_settings(pd.DataFrame(rows))


def within_authority_claim(hits: pd.DataFrame) -> list[dict[str, str]]:
    """004's first claim restricted to the hits whose need is within the measured authority, per
    predictor (004's pendulum, the short rollouts, or the oracle bound)."""
    if hits.empty:
        return []
    rows = []
    for (predictor, settings), group in variants(hits).groupby(VARIANT):
        within = group[group.within_authority.astype(bool)]
        avoided = int((~within.direction_hit).sum())
        verdict = "n/a" if within.empty else ("holds" if avoided >= 0.5 * len(within) else "does not hold")
        variant = f" ({predictor} prediction: not real time)" if predictor in ("oracle", "rollout") else ""
        variant += f" ({settings})" if settings else ""
        rows.append(
            {
                "claim (004)": "direction avoids the objects that none hits, over the hits whose needed deflection "
                f"is within the robot's measured steering authority{variant}; holds at >= 50 %",
                "verdict": verdict,
                "N/M": _ratio(avoided, len(within))
                + f"; {len(within)} of {len(group)} hits within authority"
                + f"; read at the first impact: {_avoided(group[group.within_impact_authority.astype(bool)])}",
            }
        )
    return rows


def authority_from_store(results: Path) -> pd.DataFrame:
    """The authority table of the authority suite's runs in a results store (runs stored since the
    last sweep are added first); raises FileNotFoundError without a store."""
    if (results / "runs").is_dir():
        store.consolidate(results)
    runs = store.load_metrics(results)
    return authority_table(authority_runs(runs, results))


def _spec_scenario(results: Path, run_id: str) -> dict:
    spec = YAML(typ="safe", pure=True).load((store.run_dir(results, run_id) / "spec.yaml").read_text())
    return spec["scenario"]


def footprint_rows(runs: pd.DataFrame, results: Path) -> pd.DataFrame:
    """Per `none` fall past one object (the single-object bearing suites): how far the object's
    circle lies off the fall's line, `lateral_m` = perpendicular distance of its centre from the line
    (CoM at the fall trigger, along the actual fall direction) minus its circle's radius, and
    whether the fall touched it. Objects behind the fall are left out."""
    from fallbench.analysis.safe_regions import object_circle
    from fallbench.scenario import Scenario

    single = runs[
        (runs.pre_impact == "none") & (runs.status == "ok") & runs.actual_fall_direction_deg.notna()
    ]
    rows = []
    for _, run in single.iterrows():
        scenario = Scenario.model_validate(_spec_scenario(results, run.run_id))
        if len(scenario.obstacles) != 1 or not math.isfinite(run.fall_time):
            continue
        series = store.load_timeseries(results, run.run_id)
        at = int(np.searchsorted(series.t.to_numpy(), run.fall_time))
        origin = np.array([series.com_x.iloc[at], series.com_y.iloc[at]])
        angle = math.radians(run.actual_fall_direction_deg)
        along = np.array([math.cos(angle), math.sin(angle)])
        circle = object_circle(scenario.obstacles[0])
        offset = circle.centre - origin
        if float(offset @ along) <= 0.0:
            continue
        rows.append(
            {
                "robot": scenario.robot,
                "scenario": run.scenario,
                "point": run.point,
                "hit": bool(run.obstacle_hit),
                "lateral_m": abs(float(along[0] * offset[1] - along[1] * offset[0])) - circle.radius,
            }
        )
    return pd.DataFrame(rows)


def calibrated_radius(footprints: pd.DataFrame) -> pd.DataFrame:
    """Per robot: the robot radius of 004's grown circles measured from its falls' footprints: the
    largest lateral offset (m) at which a fall still touched the object (every measured hit then lies
    inside its grown circle), beside the smallest lateral offset of a fall that stayed clear (the
    radius is consistent with the clear falls when it is below this), with the counts."""
    rows = []
    for robot, group in footprints.groupby("robot"):
        hits, clear = group[group.hit], group[~group.hit]
        rows.append(
            {
                "robot": robot,
                "falls": len(group),
                "hits": len(hits),
                "radius (m): widest hit": round(float(hits.lateral_m.max()), 3) if len(hits) else math.nan,
                "narrowest clear fall (m)": round(float(clear.lateral_m.min()), 3)
                if len(clear)
                else math.nan,
                "clear falls narrower than the radius": int((clear.lateral_m < hits.lateral_m.max()).sum())
                if len(hits)
                else 0,
            }
        )
    return pd.DataFrame(rows)


def radius_from_store(results: Path) -> pd.DataFrame:
    """`calibrated_radius` of the single-object `none` falls in a results store."""
    if (results / "runs").is_dir():
        store.consolidate(results)
    runs = store.load_metrics(results, pre_impact=["none"])
    return calibrated_radius(footprint_rows(runs, results))
