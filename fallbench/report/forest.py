"""The answer as a figure: a forest plot of each (pre-impact strategy, gain policy)'s paired change
against the unprotected fall (`none` + `stiff`) on every damage measure.

For each run of a strategy and policy, its reference is the `none` + `stiff` run of the same robot,
scenario, point and seed; the change is the run's value minus its reference's, in the measure's
unit (counts as counts, `fell` as 0/1). Each dot is the median of these paired changes (`fell` and
counts: their mean, e.g. the change in the fraction of runs that fell), each bar its 95 % percentile
bootstrap interval (`stats.bootstrap`, seeded), over the pairs. The last panel is the probability
of improvement (rliable's practice): the share of pairs in which the arm does less damage, each
pair scored by the mean over the measures of 1 (less damage), 0.5 (equal) or 0 (more), with its
interval; 0.5 = as often better as worse. Rows are ordered as in the ranking table (best mean
rank first)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report import paired
from fallbench.report.figures import _save
from fallbench.report.paired import REFERENCE, Arm
from fallbench.report.ranking import DAMAGE_MEASURES, arm_order, measures_for
from fallbench.report.stats import Estimate, bootstrap
from fallbench.report.style import colour

IMPROVEMENT = "improvement"  # the last panel: probability of improvement (paired.improvement_scores)
IMPROVEMENT_LABEL = "P(less damage) (share of pairs)"
STRATEGY_MARKERS = {"none": "o", "reshape": "s", "direction": "D"}
COLUMNS = ["pre_impact", "policy", "measure", "label", "unit", "value", "low", "high", "pairs", "reference"]


def _unit(label: str) -> str:
    """The unit in a measure's label, e.g. "N" from "head peak force (N)"; counts and fractions:
    what they count."""
    return label[label.rfind("(") + 1 : -1] if label.endswith(")") else "count"


def paired_changes(runs: pd.DataFrame, arms: list[Arm] | None = None) -> pd.DataFrame:
    """One row per (strategy, policy) other than the reference and per damage measure: the median
    (`fell` and counts: mean) of the paired changes and its 95 % interval, the number of pairs, and
    the reference's median on those pairs; then per arm its probability of improvement
    (`IMPROVEMENT`); arms in ranking order (best first) unless given."""
    ok = runs[runs.status == "ok"]
    measures = measures_for(ok)
    if paired.arm_runs(ok, REFERENCE).empty:
        return pd.DataFrame(columns=COLUMNS)
    rows = []
    for arm in arms if arms is not None else arm_order(runs):
        if arm == REFERENCE:
            continue
        pair_rows = paired.pairs(ok, arm, [m.column for m in measures])
        for measure in measures:
            change = paired.change(pair_rows, measure.column)
            theirs = pair_rows[f"{measure.column}:reference"].astype(float).to_numpy()[~np.isnan(change)]
            estimate = bootstrap(change, measure.change)
            reference = float(getattr(np, measure.statistic)(theirs)) if len(theirs) else np.nan
            rows.append(_row(arm, measure.column, measure.label, estimate, reference))
        improvement = bootstrap(paired.improvement_scores(pair_rows, measures), "mean")
        rows.append(_row(arm, IMPROVEMENT, IMPROVEMENT_LABEL, improvement, np.nan))
    return pd.DataFrame(rows, columns=COLUMNS)


def _row(arm: Arm, measure: str, label: str, estimate: Estimate, reference: float) -> dict[str, object]:
    return {
        "pre_impact": arm[0],
        "policy": arm[1],
        "measure": measure,
        "label": label,
        "unit": _unit(label),
        "value": estimate.value,
        "low": estimate.low,
        "high": estimate.high,
        "pairs": estimate.n,
        "reference": reference,
    }


def forest_figure(changes: pd.DataFrame, title: str, out: Path, stem: str) -> list[Path]:
    """One panel per measure, one row per (strategy, policy), best first from the top: dot = median
    change, bar = 95 % interval, grey line at 0 = no change against `none` + `stiff`."""
    if changes.empty:
        return []
    arms = list(dict.fromkeys(zip(changes.pre_impact, changes.policy)))
    measures = list(dict.fromkeys(changes.measure))
    lower_is_better = {m.column: m.lower_is_better for m in DAMAGE_MEASURES}
    fig, axes = plt.subplots(
        1,
        len(measures),
        figsize=(1.45 * len(measures) + 1.9, 0.36 * len(arms) + 1.6),
        sharey=True,
        squeeze=False,
    )
    y = np.arange(len(arms))[::-1]  # the best at the top
    for ax, measure in zip(axes[0], measures):
        rows = changes[changes.measure == measure].set_index(["pre_impact", "policy"]).reindex(arms)
        first = rows.iloc[0]
        ax.axvline(0.5 if measure == IMPROVEMENT else 0.0, color="grey", linewidth=1.0)
        for k, (arm, row) in enumerate(rows.iterrows()):
            if np.isnan(row.value):
                continue
            low, high = (row.low, row.high) if not np.isnan(row.low) else (row.value, row.value)
            ax.plot([low, high], [y[k], y[k]], color=colour(arm[1]), linewidth=2.2, solid_capstyle="butt")
            ax.plot(
                row.value,
                y[k],
                STRATEGY_MARKERS.get(arm[0], "^"),
                color=colour(arm[1]),
                markersize=6,
                markeredgecolor="black",
                markeredgewidth=0.6,
            )
        better = (
            "<- less damage" if lower_is_better.get(measure, measure != IMPROVEMENT) else "less damage ->"
        )
        if measure == IMPROVEMENT:
            ax.set_xlim(-0.05, 1.05)
        reference = f"ref. {first.reference:.3g}" if not np.isnan(first.reference) else ""
        ax.set_title(f"{first.label.split(' (')[0]}\n{first.unit}; {reference}", fontsize=8.5)
        ax.set_xlabel(better, fontsize=8)
        ax.tick_params(labelsize=7.5)
        ax.locator_params(axis="x", nbins=4)  # wide numbers (forces in N) do not run into each other
        for row in y[1::2]:
            ax.axhspan(row - 0.5, row + 0.5, color="#f2f2f2", zorder=0)
        ax.grid(alpha=0.3, axis="x")
    pairs = changes.groupby(["pre_impact", "policy"], sort=False).pairs.max()
    labels = [f"{s} + {p} (n={int(pairs[(s, p)])})" for s, p in arms]
    axes[0, 0].set_yticks(y, labels, fontsize=9)
    axes[0, 0].set_ylim(-0.7, len(arms) - 0.3)
    fig.suptitle(title, fontsize=10.5)
    renderer = fig.canvas.get_renderer()
    label_inches = max(t.get_window_extent(renderer).width for t in axes[0, 0].get_yticklabels()) / fig.dpi
    return _save(fig, out, stem, _margins(fig, label_inches))


def _margins(fig, label_inches: float) -> dict[str, float]:
    """Fixed margins (fractions of the figure) that hold the row labels (their measured width, in),
    the panels' two-line titles and the suptitle above, the tick labels and the direction note
    below: laying them out with tight_layout took half the figure's time."""
    width, height = fig.get_size_inches()
    return {
        "left": min(0.2 + label_inches, 0.6 * width) / width,
        "right": 1 - 0.12 / width,
        "bottom": 0.55 / height,
        "top": 1 - 0.85 / height,
        "wspace": 0.12,
    }


def forest_markdown(changes: pd.DataFrame) -> str:
    """The forest plot's numbers as a Markdown table: one row per (strategy, policy), best first."""
    if changes.empty:
        return ""
    cells = changes.assign(
        cell=[
            "n/a" if np.isnan(v) else (f"{v:+.3g}" if np.isnan(lo) else f"{v:+.3g} [{lo:+.3g}, {hi:+.3g}]")
            for v, lo, hi in zip(changes.value, changes.low, changes.high)
        ]
    )
    table = cells.pivot_table(
        index=["pre_impact", "policy"], columns="label", values="cell", aggfunc="first", sort=False
    )
    table = table[list(dict.fromkeys(changes.label))]
    return table.reset_index().to_markdown(index=False)


def draw_forest(runs: pd.DataFrame, title: str, out: Path, stem: str) -> list[Path]:
    """Compute the paired changes of `runs` and draw them (a `drawing.Figure` job)."""
    return forest_figure(paired_changes(runs), title, out, stem)
