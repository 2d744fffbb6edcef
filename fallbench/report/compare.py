"""`fallbench compare A B`: the paired change of each headline damage measure between two sets of
runs (two stores, or two selections of one), per robot, scenario family and (strategy, policy).

Runs pair when they share robot, scenario, point (swept values and seed), seed, pre-impact
strategy and policy (`KEY`; another key may be given), and both ran ok. Per group and measure the
change is B - A over the pairs: the median of the paired differences, or their mean for `fell`
(a change in the fraction of falls) and the counts, with a 95 % percentile-bootstrap interval
(report.stats.bootstrap, seeded). The verdict reads the interval: clear of 0 on the side where
the measure improves (lower, except the knee margin: higher) = `better`, on the other side =
`worse`, else `no clear change`; `no change` when every paired difference is exactly 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fallbench.analysis.metrics import HEADLINE_METRICS
from fallbench.report.figure_files import files_only
from fallbench.report.grouping import with_robot
from fallbench.report.names import arm_name
from fallbench.report.stats import bootstrap, natural_key
from fallbench.report.style import ordered

KEY = ("robot", "scenario", "point", "seed", "pre_impact", "policy")
HIGHER_IS_BETTER = {"knee_limit_margin"}
MEAN_OF_CHANGES = {"fell", "joint_limit_hits"}  # a fraction and a count: their median change is mostly 0
UNITS = {
    "imu_peak_z_landing": "m/s²",
    "contact_force_peak_head": "N",
    "contact_force_peak_torso": "N",
    "knee_limit_margin": "rad",
    "joint_limit_hits": "joints",
    "fell": "fraction",
    "takeover_delay": "s",
}
VERDICTS = ("better", "worse", "no clear change", "no change")
VERDICT_COLOURS = {
    "better": "#009E73",  # Okabe-Ito: told apart with any colour vision
    "worse": "#D55E00",
    "no clear change": "#999999",
    "no change": "#0072B2",
}


@dataclass(frozen=True)
class Comparison:
    """The paired changes (one row per robot, family, strategy, policy and measure) and the pairs."""

    table: pd.DataFrame
    pairs: int
    only_a: int
    only_b: int

    @property
    def worse(self) -> pd.DataFrame:
        return self.table[self.table.verdict == "worse"]


def pair_runs(a: pd.DataFrame, b: pd.DataFrame, key: tuple[str, ...] = KEY) -> pd.DataFrame:
    """Runs of A and B with the same key that both ran ok, side by side (`<measure>_a`, `_b`);
    a key that occurs twice in one side (it cannot pair one to one) raises ValueError."""
    a, b = with_robot(a), with_robot(b)
    for name, side in (("A", a), ("B", b)):
        missing = [k for k in key if k not in side]
        if missing:
            raise ValueError(f"{name} has no column {', '.join(missing)} to pair runs on")
        twice = side[side.status == "ok"].duplicated(list(key))
        if twice.any():
            raise ValueError(
                f"{name} holds {int(twice.sum())} runs whose key ({', '.join(key)}) another run has: "
                "select one version of them (--where-a/--where-b) or pair on more columns (--key)"
            )
    measures = [m for m in HEADLINE_METRICS if m in a and m in b]
    left = a[a.status == "ok"][list(key) + measures]
    right = b[b.status == "ok"][list(key) + measures]
    return left.merge(right, on=list(key), suffixes=("_a", "_b"))


def _verdict(measure: str, changes: np.ndarray, low: float, high: float) -> str:
    if len(changes) and np.all(changes == 0):
        return "no change"
    if np.isnan(low):
        return "no clear change"
    improves = high < 0 if measure not in HIGHER_IS_BETTER else low > 0
    worsens = low > 0 if measure not in HIGHER_IS_BETTER else high < 0
    return "better" if improves else "worse" if worsens else "no clear change"


def _row(measure: str, group: pd.DataFrame) -> dict[str, object]:
    values_a = group[f"{measure}_a"].astype(float).to_numpy()
    values_b = group[f"{measure}_b"].astype(float).to_numpy()
    both = ~np.isnan(values_a) & ~np.isnan(values_b)  # A, B and the change over the same pairs
    values_a, values_b = values_a[both], values_b[both]
    changes = values_b - values_a
    statistic = "mean" if measure in MEAN_OF_CHANGES else "median"
    estimate = bootstrap(changes, statistic)
    summary = np.nanmean if statistic == "mean" else np.nanmedian
    return {
        "measure": measure,
        "unit": UNITS.get(measure, ""),
        "statistic": f"{statistic} of B - A",
        "pairs": estimate.n,
        "A": float(summary(values_a)) if estimate.n else float("nan"),
        "B": float(summary(values_b)) if estimate.n else float("nan"),
        "change": estimate.value,
        "low": estimate.low,
        "high": estimate.high,
        "verdict": _verdict(measure, changes, estimate.low, estimate.high),
    }


def compare(a: pd.DataFrame, b: pd.DataFrame, key: tuple[str, ...] = KEY) -> Comparison:
    """The paired change of every headline measure per robot, family and (strategy, policy)."""
    pairs = pair_runs(a, b, key)
    measures = [m for m in HEADLINE_METRICS if f"{m}_a" in pairs]
    rows = []
    for (robot, family), runs in pairs.groupby(["robot", "scenario"]):
        strategies = sorted(runs.pre_impact.unique(), key=lambda s: (s != "none", s))
        for strategy in strategies:
            for policy in ordered(runs[runs.pre_impact == strategy].policy.unique()):
                group = runs[(runs.pre_impact == strategy) & (runs.policy == policy)]
                base = {"robot": robot, "family": family, "pre_impact": strategy, "policy": policy}
                rows += [base | _row(m, group) for m in measures]
    table = pd.DataFrame(rows)
    if len(table):
        order = sorted(table.family.unique(), key=natural_key)
        table = table.sort_values(
            "family", key=lambda f: f.map({name: i for i, name in enumerate(order)}), kind="stable"
        ).reset_index(drop=True)
    only_a, only_b = (int((side.status == "ok").sum()) - len(pairs) for side in (a, b))
    return Comparison(table, len(pairs), only_a, only_b)


def _interval(row: pd.Series) -> str:
    def fmt(value: float) -> str:
        return "n/a" if np.isnan(value) else f"{value:+.4g}"

    if np.isnan(row.low):
        return f"{fmt(row.change)} (n={row.pairs})"
    return f"{fmt(row.change)} [{fmt(row.low)}, {fmt(row.high)}]"


def display_table(comparison: Comparison) -> pd.DataFrame:
    """The table as people read it: A, B, the change with its interval, and the verdict."""
    table = comparison.table
    if table.empty:
        return table
    shown = table[["robot", "family", "pre_impact", "policy", "measure", "pairs"]].copy()
    shown["A"] = table.A.map(lambda v: f"{v:.4g}")
    shown["B"] = table.B.map(lambda v: f"{v:.4g}")
    shown["change B - A [95 % CI]"] = table.apply(_interval, axis=1)
    shown["verdict"] = table.verdict
    return shown


def summary_line(comparison: Comparison) -> str:
    counts = comparison.table.verdict.value_counts() if len(comparison.table) else pd.Series(dtype=int)
    parts = ", ".join(f"{int(counts.get(v, 0))} {v}" for v in VERDICTS)
    return (
        f"{comparison.pairs} paired runs ({comparison.only_a} ok runs only in A, {comparison.only_b} only "
        f"in B); {len(comparison.table)} changes (family x strategy x policy x measure): {parts}"
    )


def figure(comparison: Comparison, out: Path) -> Path:
    """compare.png: per measure, each group's change B - A with its 95 % interval, coloured by verdict."""
    import matplotlib.pyplot as plt

    files_only()
    table = comparison.table
    measures = list(dict.fromkeys(table.measure))
    groups = list(dict.fromkeys(zip(table.robot, table.family, table.pre_impact, table.policy)))
    columns = min(4, len(measures))
    rows_of_panels = -(-len(measures) // columns)
    panel_height = 0.3 * len(groups) + 1.0
    fig, axes = plt.subplots(
        rows_of_panels,
        columns,
        figsize=(3.2 * columns + 2.5, panel_height * rows_of_panels + 0.9),
        sharey=True,
        squeeze=False,
    )
    labels = [f"{(r + ' ') if r else ''}{f}: {arm_name(s, p)}" for r, f, s, p in groups]
    for ax, measure in zip(axes.flat, measures):
        for row in table[table.measure == measure].itertuples():
            y = groups.index((row.robot, row.family, row.pre_impact, row.policy))
            colour = VERDICT_COLOURS[row.verdict]
            if not np.isnan(row.low):
                ax.plot([row.low, row.high], [y, y], color=colour, lw=2)
            ax.plot([row.change], [y], "o", color=colour, ms=4)
        ax.axvline(0.0, color="black", lw=0.8)
        direction = "higher is better" if measure in HIGHER_IS_BETTER else "lower is better"
        ax.set_title(f"{measure}\n({UNITS.get(measure, '')}, {direction})", fontsize=8)
        ax.grid(alpha=0.3, axis="x")
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(measures) :]:
        ax.axis("off")
    axes[0, 0].set_yticks(range(len(groups)), labels, fontsize=7)
    axes[0, 0].set_ylim(len(groups) - 0.5, -0.5)
    handles = [plt.Line2D([], [], color=c, marker="o", lw=2, label=v) for v, c in VERDICT_COLOURS.items()]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(
        "Change B - A per family, strategy and policy: median (fell, joint hits: mean) of paired runs, 95 % CI",
        fontsize=9,
    )
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    path = out / "compare.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write(comparison: Comparison, out: Path, a_name: str, b_name: str) -> list[Path]:
    """compare.md, compare.csv (one row per change, numbers unrounded) and compare.png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    csv = out / "compare.csv"
    comparison.table.to_csv(csv, index=False)
    markdown = out / "compare.md"
    markdown.write_text(
        f"# Compare\n\nA: {a_name}\n\nB: {b_name}\n\n{summary_line(comparison)}.\n\n"
        + display_table(comparison).to_markdown(index=False)
        + "\n\n![changes](compare.png)\n"
    )
    return [markdown, csv, figure(comparison, out)]
