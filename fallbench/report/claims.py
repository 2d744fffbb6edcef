"""The qualitative claims of 002 Sec. VI, checked against our runs: holds / does not hold, with numbers."""

from __future__ import annotations

import pandas as pd

from fallbench.report.grouping import with_robot

STOP = 0.0  # rad: knee margin at or below this = the knee reached its mechanical stop


def _claims_for(runs: pd.DataFrame, scope: str) -> list[dict[str, str]]:
    by = runs.groupby("policy")
    imu = by.imu_peak_z.median()
    knee = by.knee_limit_margin.min()
    demand = by.torque_demand_ratio_max.median()
    applied = by.torque_ratio_max.max()
    rows = []

    def claim(text: str, holds: bool | None, numbers: str) -> None:
        verdict = "n/a" if holds is None else ("holds" if holds else "does not hold")
        rows.append({"scope": scope, "claim (002 Sec. VI)": text, "verdict": verdict, "numbers": numbers})

    if {"stiff"} <= set(imu.index):
        claim("stiff has the highest IMU acceleration", bool(imu.idxmax() == "stiff"),
              ", ".join(f"{p} {v:.0f}" for p, v in imu.items()) + " m/s^2 (median IMU z peak)")
        claim("stiff stays off the knee stop", bool(knee["stiff"] > STOP), f"stiff min knee margin {knee['stiff']:+.3f} rad")
    for policy in ("oneshot", "zero"):
        if policy in knee.index:
            claim(f"{policy} reaches the knee's mechanical stop", bool(knee[policy] <= STOP),
                  f"{policy} min knee margin {knee[policy]:+.3f} rad")
    if "adaptive_qp" in imu.index:
        others = imu.drop(["adaptive_qp", "stiff"], errors="ignore")
        claim("adaptive_qp has a lower IMU acceleration than stiff", bool(imu["adaptive_qp"] < imu.get("stiff", float("inf"))),
              f"adaptive_qp {imu['adaptive_qp']:.0f} vs stiff {imu.get('stiff', float('nan')):.0f} m/s^2"
              + (f" (others {', '.join(f'{p} {v:.0f}' for p, v in others.items())})" if len(others) else ""))
        claim("adaptive_qp stays off the knee stop", bool(knee["adaptive_qp"] > STOP),
              f"adaptive_qp min knee margin {knee['adaptive_qp']:+.3f} rad")
        claim("adaptive_qp keeps torques under their limits (PD demand <= limit)", bool(demand["adaptive_qp"] <= 1.0),
              f"median max demand/limit {demand['adaptive_qp']:.2f}; applied torque max/limit {applied['adaptive_qp']:.2f} (clamped by the motor)")
    return rows


def claims_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Claims over the single 1 m drop and over every drop run of the sweep, per robot."""
    runs = with_robot(runs)
    drops = runs[(runs.status == "ok") & runs.scenario.str.contains("drop") & (runs.pre_impact == "none")]
    rows: list[dict[str, str]] = []
    height = "param:initial.height"
    for robot, robot_drops in drops.groupby("robot"):
        scoped: list[dict[str, str]] = []
        if height in robot_drops.columns:
            one_metre = robot_drops[robot_drops[height] == 1.0]
            if len(one_metre):
                scoped += _claims_for(one_metre, "1 m drop")
        scoped += _claims_for(robot_drops, f"all drops ({robot_drops[height].nunique() if height in robot_drops else 1} heights)")
        rows += [{"robot": robot, **row} for row in scoped]
    return pd.DataFrame(rows)
