"""Sensitivity of the comparison to choices the papers leave open: the landing IMU peak of each
policy against a swept setting, one line per setting of adaptive_qp's own swept parameters.

- the baseline stiffness (`policy_params.stiff.gain_scale`): 002 gives no gain values, so its IMU
  ordering is shown over a range, not at one point;
- the contact softness (`contact.time_constant`): which verdicts survive a softer floor or a padded
  robot (scenarios/contact_sensitivity.yaml).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

from fallbench.report.figure_files import save_figure
from fallbench.report.grouping import with_robot
from fallbench.report.style import colour, ordered

GAIN_SCALE = "param:policy_params.stiff.gain_scale"


@dataclass(frozen=True)
class Sweep:
    """A swept setting the report shows the comparison against."""

    column: str  # the runs' parameter column
    name: str  # file stem and table column
    label: str  # the axis and the claims' scope, with its unit
    title: str  # "Sensitivity to ..."
    scope: str  # the claims' scope: "<scope> <value>"


SWEEPS = (
    Sweep(
        GAIN_SCALE,
        "gain_scale",
        "baseline gain scale (x default K, B)",
        "the baseline stiffness",
        "gain scale",
    ),
    Sweep(
        "param:contact.time_constant",
        "contact_time_constant",
        "contact time constant (s)",
        "the contact softness",
        "contact time constant (s)",
    ),
)
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


def sensitivity_runs(runs: pd.DataFrame, sweep: Sweep = SWEEPS[0]) -> pd.DataFrame:
    """Successful gain-policy-only runs with the sweep's setting, labelled per line: the policy, plus
    the values of its own swept parameters (e.g. adaptive_qp's posture_kp); the setting as `setting`."""
    if sweep.column not in runs:
        return pd.DataFrame()
    swept = with_robot(runs[(runs.status == "ok") & runs[sweep.column].notna() & (runs.pre_impact == "none")])
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
    return swept.assign(line=labels, setting=swept[sweep.column].astype(float))


def sensitivity_table(swept: pd.DataFrame, sweep: Sweep = SWEEPS[0]) -> pd.DataFrame:
    """Medians per (setting, line), one column per metric; `fell` is the fraction of runs that fell."""
    return (
        swept.astype({"fell": float})
        .groupby(["setting", "line"])[list(TABLE_METRICS)]
        .median()
        .reset_index()
        .rename(columns={"setting": sweep.name})
    )


def sensitivity_figure(swept: pd.DataFrame, out: Path, sweep: Sweep = SWEEPS[0]) -> list[Path]:
    if swept.empty or swept.setting.nunique() < 2:
        return []
    policy_of = dict(zip(swept.line, swept.policy))
    order = ordered(swept.policy.unique())
    lines = sorted(policy_of, key=lambda line: (order.index(policy_of[line]), line))
    fig, axes = plt.subplots(1, len(PANELS), figsize=(5 * len(PANELS) + 2.5, 4.2))
    for ax, (metric, label) in zip(axes, PANELS.items()):
        for i, line in enumerate(lines):
            group = swept[swept.line == line]
            medians = group.groupby("setting")[metric].median()
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
            fell = group[group.fell.astype(bool)].groupby("setting")[metric].median()
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
        ax.set_xticks(sorted(swept.setting.unique()), [f"{s:g}" for s in sorted(swept.setting.unique())])
        ax.minorticks_off()
        ax.set(xlabel=sweep.label, ylabel=label, title=label.split(" (")[0])
        ax.grid(alpha=0.3)
    axes[-1].legend(
        fontsize=8,
        title="circled: the robot fell",
        title_fontsize=8,
        bbox_to_anchor=(1.02, 1),
        loc="upper left",
    )
    from fallbench.analysis.metrics import LANDING_WINDOW  # here: the metrics import the simulation's modules

    names = ", ".join(sorted(swept.scenario.unique()))
    fig.suptitle(
        f"Sensitivity to {sweep.title} ({names}, {len(swept)} runs; landing = first "
        f"{LANDING_WINDOW * 1000:.0f} ms after impact; median over repeated points)"
    )
    return save_figure(fig, out, f"sensitivity_{sweep.name}")
