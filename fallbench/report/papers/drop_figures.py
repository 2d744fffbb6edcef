"""Figures of 002 Sec. VI for one scenario point: IMU z (Fig. 6a), right knee (Fig. 6b),
right-leg pitch torques (Fig. 4) and the adaptive gains K, B (Fig. 5). `leg` maps "hip", "knee",
"ankle" to the robot's right-leg pitch joints (RobotDescription.leg_pitch)."""

from __future__ import annotations

import textwrap
from functools import cache
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figure_files import FigureSkipped, plot_series, save_figure
from fallbench.report.stats import natural_key
from fallbench.report.style import colour, ordered
from fallbench.robots import DEFAULT_ROBOT

DASHES = ("-", "--", "-.", ":")  # per policy, in drawing order
GAINS_ZOOM = 0.25  # s after impact shown in Fig. 5's landing column (002's Fig. 5 spans about this)


def _impact_line(ax, impact: float) -> None:
    if pd.notna(impact):
        ax.axvline(impact, color="black", linestyle="--", linewidth=0.8, label="impact")


def _policy_lines(series: dict[str, pd.DataFrame], rows: pd.DataFrame, column: str):
    """One line per policy of one time-series column, impact marked."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, policy in enumerate(ordered(series)):
        ts = series[policy]
        # each line thinner and dashed its own way than the one under it: lines that coincide all show
        style = {"color": colour(policy), "linestyle": DASHES[k % len(DASHES)], "linewidth": 3.0 - 0.6 * k}
        plot_series(ax, ts.t, ts[column], label=policy, **style)
    _impact_line(ax, rows.impact_time.min())
    ax.set_xlabel("time (s)")
    ax.grid(alpha=0.3)
    return fig, ax


def _wrapped(title: str) -> str:
    """A title on lines that fit a 7-inch figure (point ids of randomised sweeps are long)."""
    return "\n".join(textwrap.wrap(title, 70, break_on_hyphens=False))


def _title_room(title: str, height: float = 4.0) -> dict[str, float]:
    """The top margin that holds a title of that many lines on a figure `height` in tall."""
    return {"top": 1 - (0.15 + 0.22 * (title.count("\n") + 1)) / height}


def imu_figure(
    series: dict[str, pd.DataFrame], rows: pd.DataFrame, title: str, out: Path, stem: str
) -> list[Path]:
    fig, ax = _policy_lines(series, rows, "imu_acc_z")
    ax.set(
        ylabel="waist IMU z acceleration, gravity included (m/s$^2$)",
        title=(wrapped := _wrapped(f"{title}: IMU z (cf. 002 Fig. 6a)")),
    )
    ax.legend()
    return save_figure(fig, out, stem, _title_room(wrapped))


def knee_figure(
    series: dict[str, pd.DataFrame],
    rows: pd.DataFrame,
    knee_limits: tuple[float, float],
    title: str,
    out: Path,
    stem: str,
    leg: dict[str, str],
) -> list[Path]:
    fig, ax = _policy_lines(series, rows, f"q:{leg['knee']}")
    for limit in knee_limits:
        ax.axhline(limit, color="black", linestyle=":", linewidth=1.0)
    ax.text(0.01, knee_limits[1], " knee limit", va="bottom", transform=ax.get_yaxis_transform())
    wrapped = _wrapped(f"{title}: right knee (cf. 002 Fig. 6b)")
    ax.set(ylabel="right knee angle (rad)", title=wrapped)
    ax.legend()
    return save_figure(fig, out, stem, _title_room(wrapped))


def torque_figure(
    series: dict[str, pd.DataFrame],
    rows: pd.DataFrame,
    torque_limits: dict[str, float],
    title: str,
    out: Path,
    stem: str,
    leg: dict[str, str],
) -> list[Path]:
    policies = ordered(series)
    fig, axes = plt.subplots(len(policies), 1, figsize=(7, 2.2 * len(policies)), sharex=True, squeeze=False)
    styles = {"hip": "-", "knee": "--", "ankle": ":"}
    for ax, policy in zip(axes[:, 0], policies):
        ts = series[policy]
        for part, joint in leg.items():
            plot_series(
                ax,
                ts.t,
                ts[f"tau:{joint}"],
                color=colour(policy),
                linestyle=styles[part],
                label=f"{part} pitch",
            )
            limit = torque_limits[joint]
            ax.axhline(limit, color="grey", linestyle="--", linewidth=0.6)
            ax.axhline(-limit, color="grey", linestyle="--", linewidth=0.6)
        _impact_line(ax, rows.impact_time.min())
        ax.set(ylabel="torque (Nm)", title=policy)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    suptitle = _wrapped(f"{title}: right-leg pitch torques, limits dashed (cf. 002 Fig. 4)")
    fig.suptitle(suptitle, fontsize=10)
    height = 2.2 * len(policies)  # in
    top = 1 - (0.45 + 0.17 * suptitle.count("\n")) / height
    return save_figure(fig, out, stem, {"bottom": 0.5 / height, "top": top})


def gains_figure(
    ts: pd.DataFrame, impact: float, title: str, out: Path, stem: str, leg: dict[str, str]
) -> list[Path]:
    """K and B of the leg's pitch joints, and the knee's velocity (from its recorded angle): 002 Fig. 5
    discusses B against the sign of the knee velocity. Left: the landing (impact - 0.05 s to impact +
    GAINS_ZOOM s, each panel scaled to it); right: the whole episode after impact."""
    fig, axes = plt.subplots(3, 2, figsize=(12, 6.5), sharex="col")
    styles = {"hip": "-", "knee": "--", "ankle": ":"}
    t = ts.t.to_numpy(dtype=float)
    start = max(impact - 0.05, 0.0) if pd.notna(impact) else 0.0
    knee = f"q:{leg['knee']}"
    for column, end in enumerate((min(start + 0.05 + GAINS_ZOOM, t[-1]), t[-1])):
        ax_k, ax_b, ax_v = axes[:, column]
        shown = (t >= start) & (t <= end)
        for part, joint in leg.items():
            plot_series(
                ax_k,
                t[shown],
                ts[f"K:{joint}"][shown],
                color=colour("adaptive_qp"),
                linestyle=styles[part],
                label=f"{part} pitch",
            )
            plot_series(
                ax_b,
                t[shown],
                ts[f"B:{joint}"][shown],
                color=colour("adaptive_qp"),
                linestyle=styles[part],
                label=f"{part} pitch",
            )
        if knee in ts:
            plot_series(
                ax_v,
                t[shown],
                np.gradient(ts[knee].to_numpy(dtype=float), t)[shown],
                color="black",
                linestyle="--",
                linewidth=1.0,
            )
            ax_v.axhline(0.0, color="grey", linewidth=0.6)
        for ax in (ax_k, ax_b, ax_v):
            _impact_line(ax, impact)
            ax.grid(alpha=0.3)
        ax_k.set(ylabel="stiffness K (Nm/rad)", title="landing" if column == 0 else "whole episode")
        ax_b.set(ylabel="damping B (Nms/rad)")
        ax_v.set(ylabel="knee velocity (rad/s)", xlabel="time (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title}: adaptive_qp gains, right leg (cf. 002 Fig. 5)")
    return save_figure(
        fig, out, stem, {"left": 0.07, "right": 0.98, "bottom": 0.08, "top": 0.9, "hspace": 0.15}
    )


# ---------------------------------------------------------------- per point: the figures of 002

NEEDED_SERIES = ("t", "imu_acc_z")  # plus the right leg's q: and tau: columns (the robot's own names)


@cache
def leg_limits(robot: str) -> tuple[dict[str, str], tuple[float, float], dict[str, float]]:
    """A robot's right-leg pitch joints, its knee range (rad, from the URDF) and their torque limits (Nm)."""
    from fallbench.scenario import Scenario
    from fallbench.sim.world import build_world

    world = build_world(Scenario(name="limits", duration=1.0, robot=robot))
    leg = world.robot.leg_pitch("right")
    low, high = world.joint_range[world.joint_names.index(leg["knee"])]
    return (
        leg,
        (float(low), float(high)),
        {j: float(world.torque_limit[world.joint_names.index(j)]) for j in leg.values()},
    )


def paper_points(runs: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """The points that can have 002's figures, as (point, its runs): successful runs without a
    pre-impact strategy (002 compares gain policies alone) under more than one policy, at the
    smallest seed of their robot and family (a randomised family gets one seed's points, not one
    per seed). Whether the runs' time series hold the columns is checked when drawing."""
    ok = runs[(runs.status == "ok") & (runs.pre_impact == "none")]
    if ok.empty:
        return []
    robots = ok.robot if "robot" in ok else pd.Series("", index=ok.index)
    first_seed = ok.groupby([robots, ok.scenario]).seed.transform("min")
    ok = ok[ok.seed == first_seed]
    points = []
    for (_, point), group in ok.groupby([robots[ok.index], ok.point], sort=False):
        if group.policy.nunique() > 1:
            points.append((point, group.drop_duplicates("policy")))
    return sorted(points, key=lambda item: natural_key(item[0]))


def point_stem(point: str, robot: str) -> str:
    stem = "".join(c if c.isalnum() else "_" for c in point).strip("_")
    return stem if robot in ("", DEFAULT_ROBOT) else f"{stem}_{robot}"


def draw_paper_figures(rows: pd.DataFrame, results: Path, out: Path, point: str) -> list[Path]:
    """Figs. 6a, 6b, 4 (and 5 with `adaptive_qp`) of one point from its runs' time series."""
    from fallbench.results import store

    robot = str(rows.robot.iloc[0]) if "robot" in rows else DEFAULT_ROBOT
    leg, knee_limits, limits = leg_limits(str(rows.robot_card.iloc[0]) if "robot_card" in rows else robot)
    series = {row.policy: store.load_timeseries(results, row.run_id) for row in rows.itertuples()}
    needed = [*NEEDED_SERIES, *(f"q:{j}" for j in leg.values()), *(f"tau:{j}" for j in leg.values())]
    lacking = sorted({c for ts in series.values() for c in needed if c not in ts})
    if lacking:
        raise FigureSkipped(f"{point}: the time series lack {', '.join(lacking)}")
    stem = point_stem(point, robot)
    paths = imu_figure(series, rows, point, out, f"fig6a_{stem}")
    paths += knee_figure(series, rows, knee_limits, point, out, f"fig6b_{stem}", leg)
    paths += torque_figure(series, rows, limits, point, out, f"fig4_{stem}", leg)
    gains = [f"{k}:{j}" for k in ("K", "B") for j in leg.values()]
    if "adaptive_qp" in series and all(c in series["adaptive_qp"] for c in gains):
        impact = rows.loc[rows.policy == "adaptive_qp", "impact_time"].iloc[0]
        paths += gains_figure(series["adaptive_qp"], impact, point, out, f"fig5_{stem}", leg)
    return paths
