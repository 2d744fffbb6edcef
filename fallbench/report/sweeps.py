"""Comparisons across all runs: metric distributions per policy, metrics against swept values."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figure_files import save_figure
from fallbench.report.grouping import with_robot
from fallbench.report.names import arm_name
from fallbench.report.stats import bootstrap
from fallbench.report.style import STRATEGY_LINES, colour, ordered
from fallbench.robots import DEFAULT_ROBOT

MAX_LINE_POINTS = 8  # more distinct values than this (a randomised key): markers only

KEY_METRICS = {
    "imu_peak_z": "IMU z peak (m/s$^2$)",
    "knee_limit_margin": "knee-limit margin (rad)",
    "torque_demand_ratio_max": "max PD demand / torque limit (-)",
    "contact_force_peak": "peak contact force (N)",
    "joint_limit_hits": "joints past a limit (count)",
}


def distribution_figure(runs: pd.DataFrame, out: Path) -> list[Path]:
    policies = ordered(runs.policy.unique())
    fig, axes = plt.subplots(1, len(KEY_METRICS), figsize=(4 * len(KEY_METRICS), 4))
    rng = np.random.default_rng(0)  # jitter only
    for ax, (metric, label) in zip(axes, KEY_METRICS.items()):
        data = [runs.loc[runs.policy == p, metric].dropna().to_numpy() for p in policies]
        box = ax.boxplot(data, patch_artist=True, showfliers=False)
        ax.set_xticks(range(1, len(policies) + 1), policies, rotation=30)
        for patch, policy in zip(box["boxes"], policies):
            patch.set(facecolor=colour(policy), alpha=0.35)
        for i, (values, policy) in enumerate(zip(data, policies), start=1):
            ax.scatter(i + rng.uniform(-0.15, 0.15, len(values)), values, s=8, color=colour(policy))
        ax.set(title=label)
        ax.grid(alpha=0.3)
    fig.suptitle(f"All runs ({len(runs)}), per policy")
    return save_figure(fig, out, "sweep_distributions")


SWEEP_METRICS = ("imu_peak_z", "knee_limit_margin", "torque_demand_ratio_max")
SWEEP_MARGINS = {"left": 0.06, "right": 0.97, "wspace": 0.3, "bottom": 0.31, "top": 0.86}  # legend below
POLAR_MARGINS = SWEEP_MARGINS | {"bottom": 0.2, "top": 0.78}  # polar titles sit above the 0 deg label
LOG_METRICS = {"torque_demand_ratio_max"}  # spans orders of magnitude (up to ~2700)
UNITS = {
    "initial.height": "m",
    "push.force": "N",
    "push.direction": "deg",
    "push.duration": "s",
    "push.start": "s",
    "friction": "-",
    "physics_dt": "s",
    "scale:force": "-",
    "scale:length": "-",
}


def parameter_figures(runs: pd.DataFrame, out: Path) -> list[Path]:
    """For each scenario family with a numeric sweep: metric medians against the swept value, with
    their 95 % bootstrap intervals (several runs per value); angles on polar axes."""
    paths: list[Path] = []
    runs = with_robot(runs)
    params = [c for c in runs.columns if c.startswith("param:")]
    for (robot, scenario), group in runs.groupby(["robot", "scenario"]):
        for param in params:
            values = group[param].dropna()
            if values.nunique() < 2 or not pd.api.types.is_numeric_dtype(values):
                continue  # string parameters (a forced mode) have no axis
            fig, margins = _sweep_figure(group, param, robot, scenario)
            stem = f"sweep_{scenario}_{param.removeprefix('param:').replace('.', '_')}"
            paths += save_figure(fig, out, stem if robot == DEFAULT_ROBOT else f"{stem}_{robot}", margins)
    return paths


def _sweep_figure(group: pd.DataFrame, param: str, robot: str, scenario: str):
    key = param.removeprefix("param:")
    angular = UNITS.get(key) == "deg"  # directions wrap: 350 deg is next to 0
    scattered = group[param].nunique() > MAX_LINE_POINTS  # randomised values: points, not lines
    fig, axes = plt.subplots(
        1, 3, figsize=(15, 5.4 if angular else 5.0), subplot_kw={"projection": "polar"} if angular else {}
    )
    for ax, metric in zip(axes, SWEEP_METRICS):
        for (strategy, policy), lines in group.groupby(["pre_impact", "policy"]):
            _sweep_line(ax, lines, param, metric, strategy, policy, scattered, angular)
        _sweep_axes(ax, metric, key, angular)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False
    )  # below, not on the data
    each = "each run" if scattered else "median [95 % CI] over seeds and the other sweep keys"
    fig.suptitle(f"{robot} {scenario}: metrics vs {key} ({each})".strip())
    return fig, POLAR_MARGINS if angular else SWEEP_MARGINS


def _sweep_line(ax, lines, param, metric, strategy, policy, scattered: bool, angular: bool) -> None:
    """One arm's medians per swept value, bars for their intervals."""
    per_value = lines.groupby(param)[metric]  # the swept values in order, NaN left out
    values = list(per_value.groups)
    estimates = [bootstrap(runs.to_numpy(dtype=float)) for _, runs in per_value]
    x = np.radians(values) if angular else np.asarray(values, dtype=float)
    y = np.array([e.value for e in estimates])
    style = {"color": colour(policy), "fillstyle": "none" if strategy == "none" else "full"}
    ax.plot(
        x,
        y,
        marker="o",
        markersize=4 if scattered else 5,
        linestyle="none" if scattered else STRATEGY_LINES.get(strategy, "-."),
        label=arm_name(strategy, policy),
        **style,
    )
    low, high = np.array([e.low for e in estimates]), np.array([e.high for e in estimates])
    if not np.isnan(low).all():
        ax.vlines(x, low, high, color=style["color"], linewidth=1.0, alpha=0.6)


def _sweep_axes(ax, metric: str, key: str, angular: bool) -> None:
    label = KEY_METRICS[metric]
    if angular:
        ax.set_theta_zero_location("N")  # 0 deg = the robot's forward, up
        ax.set_title(f"{label.split(' (')[0]}\n{label[label.find('(') :]}; angle: {_axis(key)}", fontsize=9)
        ax.tick_params(labelsize=7)
    else:
        ax.set(xlabel=_axis(key), ylabel=label, title=label.split(" (")[0])
        ax.grid(alpha=0.3)
    if metric in LOG_METRICS:
        ax.set_yscale("log") if not angular else ax.set_rscale("symlog")


def _axis(key: str) -> str:
    unit = UNITS.get(key)
    return f"{key} ({unit})" if unit else key


def median_table(runs: pd.DataFrame) -> pd.DataFrame:
    runs = with_robot(runs)
    grouped = runs.groupby(["robot", "scenario", "pre_impact", "policy"])
    table = grouped[list(KEY_METRICS)].median(numeric_only=True)
    table.insert(0, "runs", grouped.size())
    table.insert(1, "failed", grouped["status"].agg(lambda status: int((status != "ok").sum())))
    return table
