"""Sensitivity to the baseline stiffness (`policy_params.stiff.gain_scale`): the landing IMU peak of
each policy against the scale of the default gains, one line per setting of adaptive_qp's swept
parameters. 002 gives no gain values, so its IMU ordering is shown over a range, not at one point."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from fallbench.analysis.metrics import LANDING_WINDOW
from fallbench.report.figures import _save
from fallbench.report.grouping import with_robot
from fallbench.report.style import colour, ordered

GAIN_SCALE = "param:policy_params.stiff.gain_scale"
PANELS = {
    "imu_peak_z_landing": "landing IMU z peak (m/s$^2$)",
    "imu_peak_z": "whole-episode IMU z peak (m/s$^2$)",
    "knee_limit_margin": "min knee-limit margin (rad)",
}
TABLE_METRICS = (
    "imu_peak_z_landing",
    "imu_peak_z",
    "knee_limit_margin",
    "torque_demand_ratio_landing",
    "qp_failures_landing",
    "fell",
)


def value_label(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def sensitivity_runs(runs: pd.DataFrame) -> pd.DataFrame:
    """Successful gain-policy-only runs with a swept baseline gain scale, labelled per line: the policy,
    plus the values of its own swept parameters (e.g. adaptive_qp's posture_kp)."""
    if GAIN_SCALE not in runs:
        return pd.DataFrame()
    swept = with_robot(runs[(runs.status == "ok") & runs[GAIN_SCALE].notna() & (runs.pre_impact == "none")])
    own = [
        (c, *c.removeprefix("param:policy_params.").split(".", 1))
        for c in sorted(swept.columns)
        if c.startswith("param:policy_params.") and c != GAIN_SCALE
    ]  # (column, policy, key)
    several_robots = swept.robot.nunique() > 1
    labels = []
    for _, run in swept.iterrows():
        label = ", ".join(
            [str(run.policy)]
            + [
                f"{key}={value_label(run[column])}"
                for column, policy, key in own
                if policy == run.policy and pd.notna(run[column])
            ]
        )
        labels.append(label + (f" ({run.robot})" if several_robots else ""))
    return swept.assign(line=labels, gain_scale=swept[GAIN_SCALE].astype(float))


def sensitivity_table(swept: pd.DataFrame) -> pd.DataFrame:
    """Medians per (gain scale, line), one column per metric; `fell` is the fraction of runs that fell."""
    return (
        swept.astype({"fell": float})
        .groupby(["gain_scale", "line"])[list(TABLE_METRICS)]
        .median()
        .reset_index()
    )


def sensitivity_figure(swept: pd.DataFrame, out: Path) -> list[Path]:
    if swept.empty or swept.gain_scale.nunique() < 2:
        return []
    policy_of = dict(zip(swept.line, swept.policy))
    order = ordered(swept.policy.unique())
    lines = sorted(policy_of, key=lambda line: (order.index(policy_of[line]), line))
    fig, axes = plt.subplots(1, len(PANELS), figsize=(5 * len(PANELS) + 2.5, 4.2))
    for ax, (metric, label) in zip(axes, PANELS.items()):
        for i, line in enumerate(lines):
            group = swept[swept.line == line]
            medians = group.groupby("gain_scale")[metric].median()
            policy = policy_of[line]
            style = (
                "-" if "," not in line else ["--", ":", "-."][i % 3]
            )  # adaptive_qp settings: one style each
            ax.plot(
                medians.index,
                medians.to_numpy(),
                marker="o",
                color=colour(policy),
                linestyle=style,
                label=line,
            )
            fell = group[group.fell.astype(bool)].groupby("gain_scale")[metric].median()
            ax.scatter(
                fell.index,
                fell.to_numpy(),
                s=90,
                facecolors="none",
                edgecolors="black",
                linewidths=0.8,
                zorder=3,
            )
        ax.set_xscale("log")
        ax.set_xticks(
            sorted(swept.gain_scale.unique()), [f"{s:g}" for s in sorted(swept.gain_scale.unique())]
        )
        ax.minorticks_off()
        ax.set(xlabel="baseline gain scale (x default K, B)", ylabel=label, title=label.split(" (")[0])
        ax.grid(alpha=0.3)
    axes[-1].legend(
        fontsize=8,
        title="circled: the robot fell",
        title_fontsize=8,
        bbox_to_anchor=(1.02, 1),
        loc="upper left",
    )
    names = ", ".join(sorted(swept.scenario.unique()))
    fig.suptitle(
        f"Baseline stiffness sweep ({names}, {len(swept)} runs; landing = first {LANDING_WINDOW * 1000:.0f} ms "
        "after impact; median over repeated points)"
    )
    return _save(fig, out, "sensitivity_gain_scale")
