"""The qualitative claims of 002 Sec. VI, checked against our runs: holds / does not hold, with numbers.

The IMU and torque claims are judged on the landing window (the first `metrics.LANDING_WINDOW` s after
impact, what 002 Fig. 6 shows); the whole-episode values, which often record the fall that follows,
are shown next to them. Drops with a swept baseline gain scale get one scope per scale.
"""

from __future__ import annotations

import pandas as pd

from fallbench.report.grouping import with_robot
from fallbench.report.sensitivity import GAIN_SCALE, sensitivity_runs, value_label
from fallbench.report.style import ordered

STOP = 0.0  # rad: knee margin at or below this = the knee reached its mechanical stop
LANDING_COLUMNS = ["imu_peak_z_landing", "torque_demand_ratio_landing"]  # NaN in stores written before they existed


def _values(series: pd.Series, unit: str = "") -> str:
    return ", ".join(f"{p} {series[p]:.1f}" for p in ordered(series.index)) + unit


def _claims_for(runs: pd.DataFrame, scope: str) -> list[dict[str, str]]:
    runs = runs.reindex(columns=runs.columns.union(LANDING_COLUMNS, sort=False))
    by = runs.groupby("policy")
    imu = by.imu_peak_z_landing.median()
    whole = by.imu_peak_z.median()
    knee = by.knee_limit_margin.min()
    demand = by.torque_demand_ratio_landing.median()
    demand_whole = by.torque_demand_ratio_max.median()
    applied = by.torque_ratio_max.max()
    rows = []

    def claim(text: str, holds: bool | None, numbers: str) -> None:
        verdict = "n/a" if holds is None else ("holds" if holds else "does not hold")
        rows.append({"scope": scope, "claim (002 Sec. VI)": text, "verdict": verdict, "numbers": numbers})

    imu_numbers = f"landing {_values(imu)}; whole episode {_values(whole)} m/s^2 (median IMU z peak)"
    if {"stiff"} <= set(imu.index):
        claim("stiff has the highest IMU acceleration (landing)", None if imu.isna().all() else bool(imu.idxmax() == "stiff"),
              imu_numbers)
        claim("stiff stays off the knee stop", bool(knee["stiff"] > STOP), f"stiff min knee margin {knee['stiff']:+.3f} rad")
    for policy in ("oneshot", "zero"):
        if policy in knee.index:
            claim(f"{policy} reaches the knee's mechanical stop", bool(knee[policy] <= STOP),
                  f"{policy} min knee margin {knee[policy]:+.3f} rad")
    if "adaptive_qp" in imu.index:
        compared = imu.get("stiff", float("nan"))
        claim("adaptive_qp has a lower IMU acceleration than stiff (landing)",
              None if pd.isna(imu["adaptive_qp"]) or pd.isna(compared) else bool(imu["adaptive_qp"] < compared), imu_numbers)
        claim("adaptive_qp stays off the knee stop", bool(knee["adaptive_qp"] > STOP),
              f"adaptive_qp min knee margin {knee['adaptive_qp']:+.3f} rad")
        claim("adaptive_qp keeps torques under their limits (landing PD demand <= limit)",
              None if pd.isna(demand["adaptive_qp"]) else bool(demand["adaptive_qp"] <= 1.0),
              f"median max demand/limit {demand['adaptive_qp']:.2f} in the landing (joints under the policy), "
              f"{demand_whole['adaptive_qp']:.2f} over the episode (all joints); "
              f"applied torque max/limit {applied['adaptive_qp']:.2f} (clamped by the motor)")
    return rows


def _sensitivity_claims(runs: pd.DataFrame) -> list[dict[str, str]]:
    """One scope per baseline gain scale and setting of adaptive_qp's swept parameters."""
    swept = sensitivity_runs(runs)
    if swept.empty:
        return []
    settings = sorted(c for c in swept.columns if c.startswith("param:policy_params.adaptive_qp."))
    rows: list[dict[str, str]] = []
    for scale, group in swept.groupby("gain_scale"):
        subsets = group.groupby(settings, dropna=False) if settings else [((), group)]
        for values, subset in subsets:
            values = values if isinstance(values, tuple) else (values,)
            setting = ", ".join(f"{c.removeprefix('param:policy_params.')}={value_label(v)}" for c, v in zip(settings, values))
            rows += _claims_for(subset, f"{'+'.join(sorted(subset.scenario.unique()))}: gain scale {scale:g}"
                                        + (f", {setting}" if setting else ""))
    return rows


def claims_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Claims over the single 1 m drop, over every drop run of the sweep (default gains), and per
    baseline gain scale of a sensitivity sweep; per robot."""
    runs = with_robot(runs)
    drops = runs[(runs.status == "ok") & runs.scenario.str.contains("drop") & (runs.pre_impact == "none")]
    if GAIN_SCALE in drops:
        drops = drops[drops[GAIN_SCALE].fillna(1.0) == 1.0]
    rows: list[dict[str, str]] = []
    height = "param:initial.height"
    for robot, robot_runs in runs.groupby("robot"):
        robot_drops = drops[drops.robot == robot]
        scoped: list[dict[str, str]] = []
        if height in robot_drops.columns:
            one_metre = robot_drops[robot_drops[height] == 1.0]
            if len(one_metre):
                scoped += _claims_for(one_metre, "1 m drop")
        if len(robot_drops):
            scoped += _claims_for(robot_drops, f"all drops ({robot_drops[height].nunique() if height in robot_drops else 1} heights)")
        scoped += _sensitivity_claims(robot_runs)
        rows += [{"robot": robot, **row} for row in scoped]
    return pd.DataFrame(rows)
