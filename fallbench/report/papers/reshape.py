"""Pre-impact comparisons: `none` vs `reshape` per push direction, landing in clutter, and the
joint trajectories and first-contact timeline of one reshaped fall."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figure_files import FigureSkipped, save_figure
from fallbench.report.grouping import with_robot
from fallbench.report.selection import among_objects, pushed_at_set_direction, set_conditions
from fallbench.report.style import STRATEGY_LINES
from fallbench.results import store
from fallbench.robots import get_robot

DIRECTION = "param:push.direction"
STRATEGY_COLOURS = {"none": "#999999", "reshape": "#009E73"}  # Okabe-Ito grey and bluish green
TIMELINE_GROUPS = ("feet", "knees", "hands", "arms", "torso", "head")
SHORT_LABELS = {
    "front": "front",
    "back": "back",
    "side": "side",
    "front diagonal": "fr. diag.",
    "back diagonal": "bk. diag.",
}


def push_label(direction: float) -> str:
    """The fall a push from the nominal stance starts (robot facing +x): front, back, side or diagonal."""
    angle = direction % 360
    return {0: "front", 180: "back", 90: "side", 270: "side"}.get(
        angle, "front diagonal" if angle < 90 or angle > 270 else "back diagonal"
    )


def first_impact_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per robot, push class and strategy: where the first impact lands, and head and torso peak forces."""
    runs = with_robot(runs)
    pushes = runs[(runs.status == "ok") & pushed_at_set_direction(runs) & (runs.first_impact_group != "")]
    if DIRECTION not in pushes or pushes.empty:
        return pd.DataFrame()
    pushes = pushes.assign(fall=pushes[DIRECTION].map(push_label))
    rows = []
    for (robot, fall, strategy), group in pushes.groupby(["robot", "fall", "pre_impact"]):
        first = group.first_impact_group
        rows.append(
            {
                "robot": robot,
                "push": fall,
                "pre_impact": strategy,
                "falls": len(group),
                "first on hands/feet (%)": round(100 * group.first_impact_safe.mean()),
                "first on knees (%)": round(100 * first.str.contains("knees").mean()),
                "first on arms/elbows (%)": round(100 * first.str.contains("arms").mean()),
                "first on torso/head (%)": round(100 * first.str.contains("torso|head").mean()),
                "head peak median (N)": round(group.contact_force_peak_head.median()),
                "torso peak median (N)": round(group.contact_force_peak_torso.median()),
                "time to first impact median (s)": round(group.time_to_first_impact.median(), 3),
            }
        )
    return pd.DataFrame(rows)


SIDE_CLASSES = {"front": "front", "back": "back", "left": "side", "right": "side"}


def _fallen_pushes(runs: pd.DataFrame) -> pd.DataFrame:
    """Push runs that landed, with `fall` = front/back/side from the waist's lean at the first impact."""
    if "first_impact_prescribed" not in runs:
        return pd.DataFrame()
    pushes = runs[
        (runs.status == "ok")
        & pushed_at_set_direction(runs)
        & (runs.first_impact_group != "")
        & runs.fall_class.isin(list(SIDE_CLASSES))
    ]
    return pushes.assign(fall=pushes.fall_class.map(SIDE_CLASSES))


def prescription_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per fall class (at impact) and strategy: how often 000's landing order holds, knees landing
    together, head before hands, and the head, torso and IMU peaks (medians)."""
    pushes = _fallen_pushes(runs)
    if pushes.empty:
        return pd.DataFrame()
    rows = []
    for (fall, strategy), group in pushes.groupby(["fall", "pre_impact"]):
        knees = group.knees_simultaneous.dropna()
        rows.append(
            {
                "fall": fall,
                "pre_impact": strategy,
                "falls": len(group),
                "prescribed (%)": round(100 * group.first_impact_prescribed.mean()),
                "knees together": f"{int(knees.sum())}/{len(knees)}",
                "head before hands (%)": round(100 * group.head_before_hands.mean()),
                "head peak median (N)": round(group.contact_force_peak_head.median()),
                "torso peak median (N)": round(group.contact_force_peak_torso.median()),
                "IMU peak median (m/s^2)": round(group.imu_peak_norm.median()),
                "IMU z 5 ms peak median (m/s^2)": round(group.imu_peak_z_5ms.median()),
                "detection to impact median (s)": round(group.fall_lead_time.median(), 3),
            }
        )
    return pd.DataFrame(rows)


def detection_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per fall class, without reshaping: when each fall detector fired, as lead time to the first
    impact (median, s) and share of the falls it fired in before the impact."""
    pushes = _fallen_pushes(runs)
    if pushes.empty or "fall_lead_time_capture_point" not in pushes:
        return pd.DataFrame()
    rows = []
    for fall, group in pushes[pushes.pre_impact == "none"].groupby("fall"):
        row: dict[str, object] = {
            "fall": fall,
            "falls": len(group),
            "declared by": ", ".join(sorted(group.fall_reason.unique())),
        }
        for method in ("capture_point", "tilt", "freefall"):
            lead = group[f"fall_lead_time_{method}"]
            row[f"{method} fired (%)"] = round(100 * lead.notna().mean())
            row[f"{method} lead median (s)"] = round(lead.median(), 3)
        rows.append(row)
    return pd.DataFrame(rows)


def clutter_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per robot, obstacle scenario and strategy: landing error, obstacle contacts, head and torso
    peaks; on the runs among objects whose conditions were set (the regression and validation
    suites, which draw theirs, are left out)."""
    runs = with_robot(runs)
    cluttered = runs[
        (runs.status == "ok")
        & (runs.obstacle_force_peak.notna())
        & among_objects(runs)
        & set_conditions(runs)
    ]
    rows = []
    for (robot, scenario, strategy), group in cluttered.groupby(["robot", "scenario", "pre_impact"]):
        rows.append(
            {
                "robot": robot,
                "scenario": scenario,
                "pre_impact": strategy,
                "runs": len(group),
                "landing error median (m)": round(group.landing_error.median(), 3),
                "landing error max (m)": round(group.landing_error.max(), 3),
                "first on hands/feet (%)": round(100 * group.first_impact_safe.mean()),
                "head peak median (N)": round(group.contact_force_peak_head.median()),
                "torso peak median (N)": round(group.contact_force_peak_torso.median()),
                "obstacle peak median (N)": round(group.obstacle_force_peak.median()),
            }
        )
    return pd.DataFrame(rows)


def first_impact_figure(runs: pd.DataFrame, out: Path) -> list[Path]:
    pushes = runs[(runs.status == "ok") & pushed_at_set_direction(runs) & (runs.first_impact_group != "")]
    if DIRECTION not in pushes or pushes.pre_impact.nunique() < 2:
        return []
    directions = sorted(pushes[DIRECTION].unique())
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    width = 0.38
    for offset, strategy in zip((-width / 2, width / 2), ("none", "reshape")):
        group = pushes[pushes.pre_impact == strategy].groupby(DIRECTION)
        x = np.arange(len(directions)) + offset
        for ax, values in zip(
            axes,
            (
                100 * group.first_impact_safe.mean(),
                group.contact_force_peak_head.median(),
                group.contact_force_peak_torso.median(),
            ),
        ):
            ax.bar(
                x,
                values.reindex(directions).to_numpy(),
                width,
                color=STRATEGY_COLOURS[strategy],
                label=strategy,
            )
    titles = (
        "first impact on hands or feet (% of runs)",
        "head peak contact force, median (N)",
        "torso peak contact force, median (N)",
    )
    for ax, title in zip(axes, titles):
        ax.set_xticks(
            range(len(directions)), [f"{d:g}\n{SHORT_LABELS[push_label(d)]}" for d in directions], fontsize=8
        )
        ax.set(xlabel="push direction (deg, 0 = robot forward)", title=title)
        ax.grid(alpha=0.3, axis="y")
    fig.legend(
        *axes[0].get_legend_handles_labels(), title="pre-impact", loc="upper right", ncol=2, fontsize=8
    )
    fig.suptitle(
        f"Pushes from the nominal stance: none vs reshape ({len(pushes)} runs that fell, all gain policies)"
    )
    return save_figure(fig, out, "preimpact_first_impact")


def reshaped_fall_figure(runs: pd.DataFrame, results: Path, out: Path, point: str, policy: str) -> list[Path]:
    """Joint trajectories and the first-contact timeline of one point, with and without reshaping."""
    rows = runs[(runs.point == point) & (runs.policy == policy) & (runs.status == "ok")].set_index(
        "pre_impact"
    )
    rows = store.with_timeseries(results, rows)
    if not {"none", "reshape"} <= set(rows.index):
        return []
    fall = rows.loc["reshape", "fall_time"]
    if pd.isna(fall):  # e.g. a fall no detector saw: no moment to align the panels on
        raise FigureSkipped(f"reshaped fall {point}, {policy}: skipped, the reshape run has no fall_time")
    series = {s: store.load_timeseries(results, rows.loc[s, "run_id"]) for s in ("none", "reshape")}
    fig, axes = plt.subplots(1, 2, figsize=(15, 4.5), gridspec_kw={"width_ratios": [3, 2]})
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    robot = get_robot(rows.loc["reshape", "robot_card" if "robot_card" in rows else "robot"])
    for (joint, label), c in zip(robot.trajectory_joints.items(), colours):
        for strategy, ts in series.items():
            axes[0].plot(
                ts.t,
                ts[f"q:{joint}"],
                color=c,
                linestyle=STRATEGY_LINES[strategy],
                label=f"{label} ({strategy})" if strategy == "reshape" else None,
            )
    axes[0].axvline(fall, color="black", linestyle=":", linewidth=0.8, label="fall detected")
    axes[0].set(xlabel="time (s)", ylabel="joint angle (rad)", title="joints: reshape solid, none dashed")
    axes[0].legend(fontsize=7, ncol=2)
    axes[0].grid(alpha=0.3)
    for strategy, ts in series.items():
        for k, group in enumerate(TIMELINE_GROUPS):
            touching = ts[f"force:{group}"].to_numpy() > 0
            y = k + (0.2 if strategy == "reshape" else -0.2)
            axes[1].fill_between(
                ts.t,
                y - 0.15,
                y + 0.15,
                where=touching,
                color=STRATEGY_COLOURS[strategy],
                label=strategy if k == 0 else None,
                step="mid",
            )
    axes[1].set_yticks(range(len(TIMELINE_GROUPS)), TIMELINE_GROUPS)
    axes[1].set_xlim(fall - 0.1, min(series["reshape"].t.max(), fall + 1.6))
    axes[1].axvline(fall, color="black", linestyle=":", linewidth=0.8)
    axes[1].set(xlabel="time (s)", title="contact with the environment, per body group")
    axes[1].legend(fontsize=8)
    fig.suptitle(f"{point}, {policy}: reshaped fall vs none")
    stem = "reshaped_fall_" + "".join(c if c.isalnum() else "_" for c in point).strip("_") + f"_{policy}"
    return save_figure(fig, out, stem)


def reshape_points(picks) -> list[tuple[str, str]]:
    """(point, policy) of the falls the reshaped-fall figure shows: each family's typical and worst
    `reshape` falls (`filmstrips.picks`) under `stiff` (any policy when the family has no stiff),
    against `none` on the same point."""
    chosen = [p for p in picks if p.pre_impact == "reshape"]
    families = {(p.robot, p.family) for p in chosen}
    shown = []
    for robot, family in sorted(families):
        mine = [p for p in chosen if (p.robot, p.family) == (robot, family)]
        policy = "stiff" if any(p.policy == "stiff" for p in mine) else mine[0].policy
        shown += [(p.point, policy) for p in mine if p.policy == policy]
    return list(dict.fromkeys(shown))


def draw_reshaped_falls(rows: pd.DataFrame, results: Path, out: Path, point: str, policy: str) -> list[Path]:
    """`reshaped_fall_figure` as a report figure job (`rows`: the point's runs)."""
    return reshaped_fall_figure(rows, results, out, point, policy)


def preimpact_tables(runs: pd.DataFrame) -> dict[str, pd.DataFrame]:
    return {
        "First impact and head/torso peak forces of pushes, per push direction": first_impact_table(runs),
        "000's landing order per fall class (at impact), pushes": prescription_table(runs),
        "Fall detectors' lead time to the first impact, pushes without reshaping": detection_table(runs),
        "Landing among obstacles": clutter_table(runs),
    }
