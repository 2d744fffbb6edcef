"""The answer as a figure: a forest plot of each (pre-impact strategy, gain policy)'s paired change
against the unprotected fall (`none` + `stiff`) on every damage measure.

For each run of a strategy and policy, its reference is the `none` + `stiff` run of the same robot,
scenario, point and seed; the change is the run's value minus its reference's, in the measure's
unit (counts as counts, `fell` as 0/1). Each dot is the median of these paired changes (`fell`: their
mean, the change in the fraction of runs that fell), each bar its 95 % percentile bootstrap
interval (`stats.bootstrap`, seeded), over the pairs. Rows are ordered as in the ranking table
(best mean rank first)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figures import _save
from fallbench.report.ranking import DAMAGE_MEASURES, REFERENCE, arm_order, measures_for
from fallbench.report.stats import bootstrap
from fallbench.report.style import colour

PAIR_KEYS = ["robot", "scenario", "point", "seed"]
STRATEGY_MARKERS = {"none": "o", "reshape": "s", "direction": "D"}
COLUMNS = ["pre_impact", "policy", "measure", "label", "unit", "value", "low", "high", "pairs", "reference"]


def _unit(label: str) -> str:
    """The unit in a measure's label, e.g. "N" from "head peak force (N)"; counts and fractions:
    what they count."""
    return label[label.rfind("(") + 1 : -1] if label.endswith(")") else "count"


def paired_changes(runs: pd.DataFrame, arms: list[tuple[str, str]] | None = None) -> pd.DataFrame:
    """One row per (strategy, policy) other than the reference and per damage measure: the median
    (`fell`: mean) of the paired changes and its 95 % interval, the number of pairs, and the
    reference's median on those pairs; arms in ranking order (best first) unless given."""
    ok = runs[runs.status == "ok"]
    keys = [k for k in PAIR_KEYS if k in ok]
    measures = measures_for(ok)
    columns = [m.column for m in measures]
    strategy, policy = REFERENCE
    reference = ok[(ok.pre_impact == strategy) & (ok.policy == policy)].drop_duplicates(keys)
    if reference.empty:
        return pd.DataFrame(columns=COLUMNS)
    reference = reference[keys + columns]
    rows = []
    for arm in arms if arms is not None else arm_order(runs):
        if arm == REFERENCE:
            continue
        mine = ok[(ok.pre_impact == arm[0]) & (ok.policy == arm[1])].drop_duplicates(keys)
        pairs = mine[keys + columns].merge(reference, on=keys, suffixes=("", ":reference"))
        for measure in measures:
            ours = pairs[measure.column].astype(float).to_numpy()
            theirs = pairs[f"{measure.column}:reference"].astype(float).to_numpy()
            change = ours - theirs
            estimate = bootstrap(change, measure.statistic)
            paired = theirs[~np.isnan(change)]
            rows.append(
                {
                    "pre_impact": arm[0],
                    "policy": arm[1],
                    "measure": measure.column,
                    "label": measure.label,
                    "unit": _unit(measure.label),
                    "value": estimate.value,
                    "low": estimate.low,
                    "high": estimate.high,
                    "pairs": estimate.n,
                    "reference": float(getattr(np, measure.statistic)(paired)) if len(paired) else np.nan,
                }
            )
    return pd.DataFrame(rows, columns=COLUMNS)


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
        ax.axvline(0.0, color="grey", linewidth=1.0)
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
        better = "<- less damage" if lower_is_better.get(measure, True) else "less damage ->"
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
