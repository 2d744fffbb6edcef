"""Fall detection judged as a detector: when each detector would fire at each threshold of a grid,
from the signals the episode logged (`sim.events.SignalLog`), and, over a set of runs labelled by
their outcome at rest, its false-alarm rate, miss rate, lead time and delay.

Per run (metric columns, s; NaN = did not fire before a body other than the feet touched, or never):
`detect:<detector>=<threshold>` for every threshold of `GRID`. The thresholds are those of the
scenario's `detection` section: the capture point's margin outside the support polygon (m), the
torso tilt (deg), the accelerometer norm of free fall (m/s^2, held `freefall_hold` s).

Over runs (`detection_table`): a run *fell* if it ended fallen at rest (`fell`) or if a body other
than the feet touched the world on the way (a fall an object caught, the robot left leaning on
it), else it *survived*; a detector
- raises a false alarm when it fires at any time of a run that survived;
- misses a fall when it has not fired by the first touch of a body other than the feet
  (`body_contact_time`: knees, hands, torso, ...), the impact a protective strategy must prepare;
- leads by the time from its firing to that touch, and is delayed by the time from the
  disturbance's onset (`disturbance_onset`: the push's start, 0 for a drop) to its firing.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

GRID: dict[str, tuple[float, ...]] = {
    "capture_point": (-0.02, 0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3),  # m
    "tilt": (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0),  # deg
    "freefall": (1.0, 2.0, 3.0, 4.0, 6.0, 8.0),  # m/s^2
}
EARLIEST = "earliest"  # the detectors together at their defaults: the first to fire declares the fall
STRATEGY_START = "strategy start"  # the detectors (at a strategy's start margin) it starts on
UNITS = {"capture_point": "m", "tilt": "deg", "freefall": "m/s^2"}  # a set of detectors has none
SIGNAL_COLUMN = {"capture_point": 1, "tilt": 2}  # columns of the signal log compared with > threshold


def column(detector: str, threshold: float) -> str:
    return f"detect:{detector}={threshold:g}"


def fire_time(signals: np.ndarray, detector: str, threshold: float, hold: float = 0.0) -> float:
    """s at which `detector` fires at `threshold` on a signal log (t, distance, tilt, |acc| rows),
    by the online detectors' rules (sim/events.py): the capture point more than `threshold` m
    outside the support, the tilt above `threshold` deg, the accelerometer norm below `threshold`
    for `hold` s (firing time = when it dropped). NaN if it does not fire."""
    t = signals[:, 0]
    if detector in SIGNAL_COLUMN:
        above = signals[:, SIGNAL_COLUMN[detector]] > threshold  # NaN (no support) never fires
        return float(t[np.argmax(above)]) if above.any() else math.nan
    since = None
    for now, below in zip(t, signals[:, 3] < threshold):
        if not below:
            since = None
            continue
        since = now if since is None else since
        if now - since >= hold - 1e-9:
            return float(since)
    return math.nan


def detection_metrics(
    signals: np.ndarray, body_contact_time: float | None, onset: float, hold: float
) -> dict:
    """A run's detection columns: its onset and first body touch (s) and every grid firing time."""
    row: dict[str, float] = {
        "disturbance_onset": onset,
        "body_contact_time": math.nan if body_contact_time is None else float(body_contact_time),
    }
    for detector, thresholds in GRID.items():
        for threshold in thresholds:
            row[column(detector, threshold)] = fire_time(signals, detector, threshold, hold)
    return row


def detection_table(runs: pd.DataFrame, combined: dict[str, dict[str, float]] | None = None) -> pd.DataFrame:
    """Per robot, detector and threshold of `GRID`: runs survived and fell, false alarms, misses,
    their rates, and the median lead time and delay (s) over the falls it caught. `runs` are
    metric rows (one per fall, `fell` judged at rest). With `combined` (name -> detector ->
    threshold), also each set of detectors together, firing when the earliest of them fires (as
    the fall is declared, `EARLIEST`, or a strategy starts, `STRATEGY_START`)."""
    rows = []
    for robot, group in runs.groupby("robot", sort=True):
        contact = group["body_contact_time"].to_numpy(dtype=float)
        # a fall caught by an object (a robot left leaning on a table) is a fall to detect too
        fell = group["fell"].astype(bool).to_numpy() | np.isfinite(contact)
        onset = group["disturbance_onset"].to_numpy(dtype=float)
        for detector, thresholds in GRID.items():
            for threshold in thresholds:
                if column(detector, threshold) not in group:
                    continue
                fired = group[column(detector, threshold)].to_numpy(dtype=float)
                rows.append(_scores(robot, detector, threshold, fired, fell, contact, onset))
        for name, thresholds in (combined or {}).items():
            columns = [column(d, t) for d, t in thresholds.items()]
            if all(c in group for c in columns):
                earliest = group[columns].min(axis=1, skipna=True).to_numpy(dtype=float)
                rows.append(_scores(robot, name, math.nan, earliest, fell, contact, onset))
    return pd.DataFrame(rows)


def _scores(
    robot: str,
    detector: str,
    threshold: float,
    fired: np.ndarray,
    fell: np.ndarray,
    contact: np.ndarray,
    onset: np.ndarray,
) -> dict[str, object]:
    caught = fell & np.isfinite(fired) & (fired < np.where(np.isfinite(contact), contact, np.inf))
    false_alarms = int((~fell & np.isfinite(fired)).sum())
    survived, falls = int((~fell).sum()), int(fell.sum())
    lead = (contact - fired)[caught & np.isfinite(contact)]
    return {
        "robot": robot,
        "detector": detector,
        "threshold": threshold,
        "unit": UNITS.get(detector, ""),
        "survived": survived,
        "false_alarms": false_alarms,
        "false_alarm_rate": false_alarms / survived if survived else math.nan,
        "fell": falls,
        "misses": falls - int(caught.sum()),
        "miss_rate": (falls - int(caught.sum())) / falls if falls else math.nan,
        "lead_median_s": float(np.median(lead)) if len(lead) else math.nan,
        "delay_median_s": float(np.median((fired - onset)[caught])) if caught.any() else math.nan,
    }
