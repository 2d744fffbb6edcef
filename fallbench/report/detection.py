"""The fall-detection page: every detector judged as a detector on the store's none + stiff runs
(each a fall or survived, analysis/detection.py's labels), its trade-off between false alarms, misses and lead time
over the threshold grid, and the scenario default's point on it (analysis/detection.py)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd

import fallbench.report.pages as pages
from fallbench.analysis.detection import EARLIEST, GRID, STRATEGY_START, detection_table
from fallbench.report.drawing import Drawn, Figure
from fallbench.report.figure_files import save_figure
from fallbench.scenario import Detection

PAGE = "detection.html"
MIN_RUNS = 10  # per robot: fewer none + stiff runs say nothing about a detector
DEFAULTS = {
    "capture_point": Detection().capture_point_margin,
    "tilt": Detection().tilt,
    "freefall": Detection().freefall,
}


def strategy_starts() -> dict[str, float]:
    """Strategy name -> its default start margin (m), for the registered strategies that start on
    their own capture-point margin rather than on the declared fall."""
    from fallbench.registry import strategies  # here: it imports every controller and its dynamics

    starts = {name: strategy.default_start_margin() for name, strategy in strategies().items()}
    return {name: margin for name, margin in sorted(starts.items()) if margin is not None}


def start_key(name: str, starts: dict[str, float]) -> str:
    """The combined detector's name of strategy `name`'s start: `STRATEGY_START` when one strategy
    declares a start margin, one per strategy when several do."""
    return STRATEGY_START if len(starts) == 1 else f"{STRATEGY_START} ({name})"


def combined() -> dict[str, dict[str, float]]:
    """The combined detectors judged beside the single ones: the three at their defaults (the
    earliest declares), and what starts each strategy with a start margin of its own (the capture
    point at that margin, or the tilt)."""
    starts = strategy_starts()
    started = {
        start_key(name, starts): {"capture_point": margin, "tilt": Detection().tilt}
        for name, margin in starts.items()
    }
    return {EARLIEST: DEFAULTS} | started


def combined_markers() -> dict[str, tuple[str, str]]:
    """Combined detector -> (marker, legend label) on the trade-off figure."""
    starts = strategy_starts()
    started = {start_key(name, starts): ("P", f"{name} starts") for name in starts}
    return {EARLIEST: ("*", "earliest of the three")} | started


MARKERS = {EARLIEST: ("*", "earliest of the three"), STRATEGY_START: ("P", "reshape starts")}
MARKERS = {"capture_point": "o", "tilt": "s", "freefall": "^"}
COLUMNS = {
    "detector": "detector",
    "threshold": "threshold",
    "unit": "unit",
    "survived": "survived",
    "false_alarms": "false alarms",
    "false_alarm_rate": "false-alarm rate",
    "fell": "fell",
    "misses": "misses",
    "miss_rate": "miss rate",
    "lead_median_s": "median lead (s)",
    "delay_median_s": "median delay (s)",
}


def detection_runs(runs: pd.DataFrame) -> pd.DataFrame:
    """The runs that judge the detectors: none + stiff (nothing acts on a detection), with their
    detection columns, on robots with at least MIN_RUNS of them."""
    if "body_contact_time" not in runs:
        return runs.iloc[0:0]
    mine = runs[(runs.pre_impact == "none") & (runs.policy == "stiff") & (runs.status == "ok")]
    mine = mine[mine["disturbance_onset"].notna()]
    counts = mine.groupby("robot")["run_id"].transform("size")
    return mine[counts >= MIN_RUNS]


def trade_off_figure(table: pd.DataFrame, out: Path) -> list[Path]:
    """Per robot: false-alarm rate against miss rate, and against median lead time, one line per
    detector through its thresholds; the default threshold circled."""
    robots = sorted(table.robot.unique())
    fig, axes = plt.subplots(len(robots), 2, figsize=(10, 4 * len(robots)), squeeze=False)
    for row, robot in zip(axes, robots):
        for detector in GRID:
            mine = table[(table.robot == robot) & (table.detector == detector)]
            default = mine[mine.threshold == DEFAULTS[detector]]
            for ax, y in zip(row, ("miss_rate", "lead_median_s")):
                ax.plot(mine.false_alarm_rate, mine[y], marker=MARKERS[detector], label=detector)
                ax.plot(default.false_alarm_rate, default[y], "o", ms=14, mfc="none", mec="black")
        for name, (marker, label) in combined_markers().items():
            mine = table[(table.robot == robot) & (table.detector == name)]
            for ax, y in zip(row, ("miss_rate", "lead_median_s")):
                ax.plot(mine.false_alarm_rate, mine[y], marker, ms=14, color="black", label=label)
        row[0].set(
            xlabel="false-alarm rate (runs survived)", ylabel="miss rate (falls)", title=f"{robot}: misses"
        )
        row[1].set(
            xlabel="false-alarm rate (runs survived)", ylabel="median lead time (s)", title=f"{robot}: lead"
        )
        row[0].legend(title="circled: default threshold", fontsize=9)
    return save_figure(fig, out, "detection_trade_off")


def detection_figure(judged: pd.DataFrame, out: Path) -> tuple[list[Path], pd.DataFrame]:
    """The trade-off figure of the judged runs (`detection_runs`) and its table: a drawing job."""
    table = detection_table(judged, combined())
    return trade_off_figure(table, out), table


JOB = "detection"  # the name of `detection_job`'s figure


def detection_job(runs: pd.DataFrame, out: Path) -> list[Figure]:
    """`detection_figure` of the store's runs as a job for `drawing.Drawing`; none if too few runs."""
    judged = detection_runs(runs)
    return [] if judged.empty else [Figure(JOB, detection_figure, (judged, out), ())]


def detection_section(runs: pd.DataFrame, out: Path, drawn: Drawn | None = None) -> Path | None:
    """Write detection.html from the store's none + stiff runs; None if too few of them. With
    `drawn`: its figure and table as `detection_job` drew them, else drawn here."""
    judged = detection_runs(runs)
    if judged.empty:
        return None
    starts = strategy_starts()
    if drawn is not None and JOB in drawn.payloads:
        figures, table = drawn.paths[JOB], drawn.payloads[JOB]
    else:
        figures, table = detection_figure(judged, out)
    body = [
        "<h1>Fall detection</h1>",
        f"<p>{len(judged)} runs under none + stiff, each a fall (fallen at rest, or a body other than the "
        "feet touched on the way: an object caught it) or survived. A false alarm: "
        "the detector fired in a run that survived. A miss: it had not fired when a body other than "
        "the feet first touched. Lead: from firing to that touch. Delay: from the disturbance's "
        "onset (the push's start, 0 for a drop) to firing. Defaults: "
        + ", ".join(f"{d} {v:g}" for d, v in DEFAULTS.items())
        + "; 'earliest': the three together at their defaults, the first to fire declaring the fall, "
        "as a scenario's default `detection` does"
        + "".join(
            f"; '{start_key(name, starts)}': the capture point at {name}'s default start margin "
            f"({margin:g} m) or the tilt, the first to fire starting {name}"
            for name, margin in starts.items()
        )
        + " (docs/detection.md).</p>",
    ]
    body += [pages.image(p, out) for p in figures if p.suffix == ".png"]
    for robot, mine in table.groupby("robot"):
        body += [
            f"<h2>{robot}</h2>",
            pages.table(mine.drop(columns="robot").rename(columns=COLUMNS).round(3)),
        ]
    return pages.write(out / PAGE, "fallbench: fall detection", body)
