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

import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.ticker import FuncFormatter, MaxNLocator

import fallbench.report.paired as paired
from fallbench.report.figure_files import save_figure
from fallbench.report.paired import REFERENCE
from fallbench.report.ranking import DAMAGE_MEASURES, Ranked, arm_order, measures_for, ranked, row_name
from fallbench.report.stats import Estimate, bootstrap, natural_sorted
from fallbench.report.style import colour

IMPROVEMENT = "improvement"  # the last panel: probability of improvement (paired.improvement_scores)
IMPROVEMENT_LABEL = "P(less damage) (share of pairs)"
STRATEGY_MARKERS = {"none": "o", "reshape": "s", "direction": "D"}
COLUMNS = [
    *("pre_impact", "policy", "name", "measure", "label", "unit"),
    *("value", "low", "high", "pairs", "reference", "zero_references"),
]


def _unit(label: str) -> str:
    """The unit in a measure's label, e.g. "N" from "head peak force (N)"; counts and fractions:
    what they count."""
    return label[label.rfind("(") + 1 : -1] if label.endswith(")") else "count"


def paired_changes(runs: pd.DataFrame, done: Ranked | None = None) -> pd.DataFrame:
    """One row per ranking row other than the reference and per damage measure: the median
    (`fell` and counts: mean) of the paired changes and its 95 % interval, the number of pairs,
    the reference's median on this row's own pairs and how many of them are 0; then per row its
    probability of improvement (`IMPROVEMENT`); best mean rank first."""
    runs = paired.narrow(runs, measures_for(runs))
    ok = runs[runs.status == "ok"]
    measures = measures_for(ok)
    indexed = paired.ArmRuns(ok)
    if not len(indexed.first_rows(REFERENCE)):
        return pd.DataFrame(columns=COLUMNS)
    done = done or ranked(runs)
    columns = [m.column for m in measures]
    rows = []
    for arm in arm_order(runs, done):
        if arm == REFERENCE:
            continue
        pair_rows = indexed.pairs(arm, columns)
        base = {"pre_impact": arm[0], "policy": arm[1], "name": row_name(done, arm)}
        for measure in measures:
            change = paired.change(pair_rows, measure.column)
            theirs = pair_rows[f"{measure.column}:reference"].astype(float).to_numpy()[~np.isnan(change)]
            estimate = bootstrap(change, measure.change)
            reference = float(getattr(np, measure.statistic)(theirs)) if len(theirs) else np.nan
            row = _row(measure.column, measure.label, estimate, reference)
            rows.append(base | row | {"zero_references": int((theirs == 0).sum())})
        improvement = bootstrap(paired.improvement_scores(pair_rows, measures), "mean")
        rows.append(base | _row(IMPROVEMENT, IMPROVEMENT_LABEL, improvement, np.nan))
    return pd.DataFrame(rows, columns=COLUMNS)


def _row(measure: str, label: str, estimate: Estimate, reference: float) -> dict[str, object]:
    return {
        "measure": measure,
        "label": label,
        "unit": _unit(label),
        "value": estimate.value,
        "low": estimate.low,
        "high": estimate.high,
        "pairs": estimate.n,
        "reference": reference,
        "zero_references": 0,
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
    panels: dict[str, dict[tuple[str, str], Any]] = {measure: {} for measure in measures}
    for change in changes.itertuples(index=False):  # a panel's rows by arm, read once
        panels[change.measure][(change.pre_impact, change.policy)] = change
    for ax, measure in zip(axes[0], measures):
        rows = [panels[measure].get(arm) for arm in arms]  # None: the arm lacks the measure
        _panel(ax, measure, arms, rows, y, lower_is_better)
    pairs = changes.groupby(["pre_impact", "policy"], sort=False).pairs.max()
    names = changes.drop_duplicates(["pre_impact", "policy"]).set_index(["pre_impact", "policy"]).name
    labels = [f"{names[arm]} (n={int(pairs[arm])})" for arm in arms]
    axes[0, 0].set_yticks(y, labels, fontsize=9)
    axes[0, 0].set_ylim(-0.7, len(arms) - 0.3)
    fig.suptitle(title, fontsize=10.5)
    title_lines = title.count("\n") + 1
    renderer = fig.canvas.get_renderer()
    label_inches = max(t.get_window_extent(renderer).width for t in axes[0, 0].get_yticklabels()) / fig.dpi
    return save_figure(fig, out, stem, _margins(fig, label_inches, title_lines))


def _panel(
    ax,
    measure: str,
    arms: list[tuple[str, str]],
    rows: list[Any],
    y: np.ndarray,
    lower_is_better: dict[str, bool],
) -> None:
    """One measure's panel of the forest plot: each arm's median change (dot) and 95 % interval (bar)
    on its row `y` (`rows[k]` None: arm k lacks the measure), the line of no change, the axis and its
    title."""
    first = rows[0]
    references = pd.unique(pd.Series([r.reference for r in rows if r is not None]).dropna())
    ax.axvline(0.5 if measure == IMPROVEMENT else 0.0, color="grey", linewidth=1.0)
    for k, (arm, row) in enumerate(zip(arms, rows)):
        if row is None or np.isnan(row.value):
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
    better = "<- less damage" if lower_is_better.get(measure, measure != IMPROVEMENT) else "less damage ->"
    if measure == IMPROVEMENT:
        ax.set_xlim(-0.05, 1.05)
    # the reference's median on each row's own pairs: one value in the title when they agree
    reference = {0: "", 1: f"; ref. {references[0]:.3g}" if len(references) else ""}.get(
        len(references), "; ref. per row: table"
    )
    ax.set_title(f"{first.label.split(' (')[0]}\n{first.unit}{reference}", fontsize=8.5)
    ax.set_xlabel(better, fontsize=8)
    ax.tick_params(labelsize=7.5)
    ax.xaxis.set_major_locator(MaxNLocator(nbins=3))  # wide numbers (forces in N) stay apart
    ax.xaxis.set_major_formatter(FuncFormatter(_short_number))
    shown = [[r.low, r.high, r.value] for r in rows if r is not None]
    if measure != IMPROVEMENT and not np.nanmax(np.abs(np.array(shown, dtype=float)), initial=0):
        ax.set_xlim(-1.0, 1.0)  # every change 0: a readable axis, not +-0.05
    for row in y[1::2]:
        ax.axhspan(row - 0.5, row + 0.5, color="#f2f2f2", zorder=0)
    ax.grid(alpha=0.3, axis="x")


def _short_number(value: float, _position: int = 0) -> str:
    """Tick labels that fit a narrow panel: 12000 -> "12k", 0.25 -> "0.25"."""
    return f"{value / 1000:g}k" if abs(value) >= 1000 else f"{value:g}"


def _margins(fig, label_inches: float, title_lines: int = 1) -> dict[str, float]:
    """Fixed margins (fractions of the figure) that hold the row labels (their measured width, in),
    the panels' two-line titles and the suptitle above, the tick labels and the direction note
    below: laying them out with tight_layout took half the figure's time."""
    width, height = fig.get_size_inches()
    return {
        "left": min(0.2 + label_inches, 0.6 * width) / width,
        "right": 1 - 0.12 / width,
        "bottom": 0.55 / height,
        "top": 1 - (0.68 + 0.17 * title_lines) / height,
        "wspace": 0.12,
    }


def forest_table(changes: pd.DataFrame) -> pd.DataFrame:
    """The forest plot's numbers, one row per ranking row (best first): pairs, then per measure the
    change [95 % CI] and the reference's median on the row's own pairs, with how many of those
    pairs have a reference of 0 (a change is a difference, so they count like any other pair)."""
    if changes.empty:
        return pd.DataFrame()
    rows = []
    for name, arm in changes.groupby("name", sort=False):
        row: dict[str, object] = {"arm": name, "pairs": int(arm.pairs.max())}
        for change in arm.itertuples():
            row[change.label] = _cell(change)
        rows.append(row)
    return pd.DataFrame(rows)


def _cell(change) -> str:
    if np.isnan(change.value):
        return "n/a"
    cell = f"{change.value:+.3g}"
    if not np.isnan(change.low):
        cell += f" [{change.low:+.3g}, {change.high:+.3g}]"
    if np.isnan(change.reference):
        return cell
    zeros = f", 0 in {change.zero_references}/{change.pairs}" if change.zero_references else ""
    return f"{cell} (ref. {change.reference:.3g}{zeros})"


def forest_markdown(changes: pd.DataFrame) -> str:
    """`forest_table` in Markdown."""
    table = forest_table(changes)
    return table.to_markdown(index=False) if len(table) else ""


@dataclass(frozen=True)
class Pool:
    """Families of one robot in which the same arms ran, and their pooled paired changes."""

    families: list[str]
    changes: pd.DataFrame

    def title(self, robot: str, total: int) -> str:
        """ "talos: 10 of 18 families where the same arms ran:" and, wrapped, which."""
        head = f"{robot}: {len(self.families)} of {total} families where the same arms ran:".lstrip(": ")
        return head + "\n" + "\n".join(textwrap.wrap(", ".join(self.families), 150))


def pools(robot_runs: pd.DataFrame) -> list[Pool]:
    """The robot's families grouped by the set of arms that ran in them, the most runs first: a
    pooled forest row then covers the same families as every other row."""
    ok = robot_runs[robot_runs.status == "ok"]
    arm_sets: dict[frozenset, list[str]] = {}
    for family, runs in ok.groupby("scenario"):
        arm_sets.setdefault(frozenset(zip(runs.pre_impact, runs.policy)), []).append(str(family))
    groups = sorted(arm_sets.values(), key=lambda fs: -int(ok.scenario.isin(fs).sum()))
    return [
        Pool(natural_sorted(families), paired_changes(robot_runs[robot_runs.scenario.isin(families)]))
        for families in groups
    ]
