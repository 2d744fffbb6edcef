"""Comparisons across all runs: metric distributions per policy, metrics against swept values."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figures import _save
from fallbench.report.grouping import with_robot
from fallbench.report.names import arm_name
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
    return _save(fig, out, "sweep_distributions")


def parameter_figures(runs: pd.DataFrame, out: Path) -> list[Path]:
    """For each scenario family with a numeric sweep: metric medians against the swept value."""
    paths: list[Path] = []
    runs = with_robot(runs)
    params = [c for c in runs.columns if c.startswith("param:")]
    for (robot, scenario), group in runs.groupby(["robot", "scenario"]):
        for param in params:
            values = group[param].dropna()
            if values.nunique() < 2 or not pd.api.types.is_numeric_dtype(
                values
            ):  # string parameters (a forced mode) have no axis
                continue
            scattered = values.nunique() > MAX_LINE_POINTS  # randomised values: points, not lines
            fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
            for ax, metric in zip(axes, ["imu_peak_z", "knee_limit_margin", "torque_demand_ratio_max"]):
                for (strategy, policy), lines in group.groupby(["pre_impact", "policy"]):
                    medians = lines.groupby(param)[metric].median()
                    ax.plot(
                        medians.index,
                        medians.to_numpy(),
                        marker="o",
                        color=colour(policy),
                        markersize=4 if scattered else 6,
                        linestyle="none" if scattered else STRATEGY_LINES.get(strategy, "-."),
                        label=arm_name(strategy, policy),
                        fillstyle="none" if strategy == "none" else "full",
                    )
                ax.set(
                    xlabel=_axis(param), ylabel=KEY_METRICS[metric], title=KEY_METRICS[metric].split(" (")[0]
                )
                ax.grid(alpha=0.3)
            axes[0].legend(fontsize=8)
            fig.suptitle(
                f"{robot} {scenario}: metrics vs {param.removeprefix('param:')} (median over the other sweep keys)"
            )
            stem = f"sweep_{scenario}_{param.removeprefix('param:').replace('.', '_')}"
            paths += _save(fig, out, stem if robot == DEFAULT_ROBOT else f"{stem}_{robot}")
    return paths


def _axis(param: str) -> str:
    key = param.removeprefix("param:")
    units = {
        "initial.height": "m",
        "push.force": "N",
        "push.direction": "deg",
        "push.duration": "s",
        "friction": "-",
    }
    return f"{key} ({units.get(key, '')})"


def median_table(runs: pd.DataFrame) -> pd.DataFrame:
    runs = with_robot(runs)
    grouped = runs.groupby(["robot", "scenario", "pre_impact", "policy"])
    table = grouped[list(KEY_METRICS)].median(numeric_only=True)
    table.insert(0, "runs", grouped.size())
    table.insert(1, "failed", grouped.apply(lambda g: int((g.status != "ok").sum()), include_groups=False))
    return table
