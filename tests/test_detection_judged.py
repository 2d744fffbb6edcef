"""Fall detection judged as a detector (analysis/detection.py): firing times from a signal log by
the online detectors' rules, the scores over labelled runs by hand, and a simulated fall whose
logged signals give the online detectors' own firing times."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from fallbench.analysis.detection import column, detection_table, fire_time
from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.scenario import Push, Scenario
from fallbench.sim.events import FallWatch


def _log(distance: list[float], tilt: list[float], acc: list[float], dt: float = 0.005) -> np.ndarray:
    t = np.arange(len(tilt)) * dt
    return np.column_stack([t, distance, tilt, acc])


def test_each_detector_fires_at_its_first_crossing() -> None:
    log = _log([math.nan, -0.1, 0.03, 0.2, 0.1], [1, 4, 12, 16, 30], [9.8, 2, 2, 9.8, 1])
    assert fire_time(log, "capture_point", 0.02) == pytest.approx(0.010)
    assert fire_time(log, "capture_point", 0.1) == pytest.approx(0.015)
    assert math.isnan(fire_time(log, "capture_point", 0.3))
    assert fire_time(log, "tilt", 15) == pytest.approx(0.015)
    assert math.isnan(fire_time(log, "tilt", 30))  # above, not at


def test_freefall_needs_its_whole_hold_and_fires_when_it_dropped() -> None:
    log = _log([0.0] * 6, [0.0] * 6, [9.8, 2, 2, 9.8, 1, 1])  # below for 5 ms, then again from 20 ms
    assert fire_time(log, "freefall", 3, hold=0.005) == pytest.approx(0.005)
    assert math.isnan(fire_time(log, "freefall", 3, hold=0.006))
    assert math.isnan(fire_time(log, "freefall", 0.5, hold=0.0))


def _runs() -> pd.DataFrame:
    """Four runs by hand: two falls (body touches at 1.0 s), two survived; onset 0.1 s."""
    runs = pd.DataFrame(
        {
            "robot": "talos",
            "fell": [True, True, False, False],
            "body_contact_time": [1.0, 1.0, math.nan, math.nan],
            "disturbance_onset": 0.1,
        }
    )
    runs[column("tilt", 15.0)] = [0.4, math.nan, 2.0, math.nan]  # caught, missed, false alarm, quiet
    return runs


def test_scores_by_hand() -> None:
    table = detection_table(_runs())
    row = table[(table.detector == "tilt") & (table.threshold == 15.0)].iloc[0]
    assert (row.survived, row.false_alarms, row.fell, row.misses) == (2, 1, 2, 1)
    assert row.false_alarm_rate == 0.5 and row.miss_rate == 0.5
    assert row.lead_median_s == pytest.approx(0.6) and row.delay_median_s == pytest.approx(0.3)
    assert set(table.detector) == {"tilt"}  # only the columns the runs hold


def test_detectors_together_fire_with_the_earliest_of_them() -> None:
    runs = _runs()
    runs[column("capture_point", 0.1)] = [0.2, 0.9, math.nan, math.nan]  # earlier, and catches the miss
    together = {"capture_point": 0.1, "tilt": 15.0}
    table = detection_table(runs, {"start": together, "absent": {"freefall": 3.0}})
    row = table[table.detector == "start"].iloc[0]
    assert (row.false_alarms, row.misses) == (1, 0)  # the tilt's false alarm, no miss
    assert row.lead_median_s == pytest.approx(0.45)  # leads 0.8 and 0.1 s
    assert "absent" not in set(table.detector)  # a set whose columns the runs do not hold


def test_a_detector_firing_after_the_body_touched_misses() -> None:
    runs = _runs()
    runs.loc[0, column("tilt", 15.0)] = 1.0  # at the touch itself: too late
    row = detection_table(runs).iloc[0]
    assert row.misses == 2 and math.isnan(row.lead_median_s)


def test_logged_signals_give_the_online_firing_times_on_a_fall() -> None:
    """TALOS pushed over (370 N): the grid's default thresholds fire when the online detectors did,
    and the body's first touch comes after them."""
    rec = simulate_named(
        Scenario(name="p", duration=2.0, push=Push(force=370, direction=0, duration=0.1)), "stiff"
    )
    row = compute_metrics(rec)
    assert row["fell"] is True
    assert row[column("capture_point", 0.02)] == row["fall_time_capture_point"]
    assert row[column("tilt", 15.0)] == row["fall_time_tilt"]
    assert row["disturbance_onset"] == 0.1
    assert row["fall_time_tilt"] < row["body_contact_time"] < 2.0
    assert rec.detection_signals[-1, 0] < row["body_contact_time"]


def test_the_report_page_needs_enough_none_stiff_runs(tmp_path) -> None:
    from fallbench.report.detection import MIN_RUNS, detection_section

    runs = pd.concat([_runs()] * 3, ignore_index=True)  # 12 runs
    runs = runs.assign(
        run_id=[f"r{i}" for i in range(len(runs))], pre_impact="none", policy="stiff", status="ok"
    )
    page = detection_section(runs, tmp_path)
    assert page is not None and (tmp_path / "detection_trade_off.png").exists()
    assert "talos" in page.read_text() and "false-alarm rate" in page.read_text()
    assert detection_section(runs.iloc[: MIN_RUNS - 1], tmp_path / "few") is None
    assert detection_section(runs.assign(policy="adaptive_qp"), tmp_path / "other") is None


def test_each_strategy_starting_on_its_own_margin_is_judged(monkeypatch: pytest.MonkeyPatch) -> None:
    """The page judges what starts every registered strategy with a start margin of its own, read
    from the strategy's defaults: reshape's alone today, and a plug-in's beside it."""
    from fallbench.preimpact.none import NoStrategy
    from fallbench.registry import strategies
    from fallbench.report.detection import STRATEGY_START, combined, strategy_starts

    assert strategy_starts() == {"reshape": 0.1}
    assert combined()[STRATEGY_START]["capture_point"] == 0.1

    class EarlyStart(NoStrategy):
        name = "early_start"
        start_margin = 0.05

    monkeypatch.setitem(strategies(), "early_start", EarlyStart)
    assert strategy_starts() == {"early_start": 0.05, "reshape": 0.1}
    assert combined()[f"{STRATEGY_START} (early_start)"]["capture_point"] == 0.05


def test_a_fall_is_over_after_a_whole_hold_inside_the_support_and_upright() -> None:
    watch = FallWatch(margin=0.01, tilt=15.0, hold=0.05)
    steps = [(0.0, 0.2, 5), (0.01, -0.02, 5), (0.02, math.nan, 5), (0.03, -0.02, 5), (0.05, -0.02, 20)]
    assert not any(watch.update(t, d, tilt) for t, d, tilt in steps)  # outside, no support, tilted
    assert not watch.update(0.06, -0.005, 5)  # inside, but by less than the margin
    verdicts = [watch.update(t, -0.02, 5) for t in (0.07, 0.10, 0.12, 0.13)]
    assert verdicts == [False, False, True, False] and watch.time == 0.12  # once, after 0.05 s


def _reshaped(force: float, start_margin: float = 0.1, **detection: object) -> dict[str, object]:
    scenario = Scenario(
        name="p",
        push=Push(force=force, direction=0, duration=0.1),
        detection=detection,
        policy_params={"reshape": {"start_margin": start_margin}},
    )
    return compute_metrics(simulate_named(scenario, "stiff", "reshape"))


def test_a_false_alarm_is_handed_back_and_the_robot_stays_up() -> None:
    """A push TALOS survives (235 N) with an eager capture-point margin (-3 cm) starts `reshape`;
    its fall does not go on, so it hands back and TALOS stays up; kept reshaping, it falls."""
    eager = {"capture_point_margin": -0.03}
    row = _reshaped(235, start_margin=-0.03, **eager)
    assert row["strategy_start_time"] == row["fall_time"] and 0.1 < row["fall_time"] < 0.3
    assert row["hand_back_time"] == pytest.approx(row["fall_time"] + 0.1) and row["fell"] is False
    kept = _reshaped(235, start_margin=-0.03, **eager, hand_back=False)
    assert math.isnan(kept["hand_back_time"]) and kept["fell"] is True


def test_a_false_alarm_within_the_start_margin_starts_no_reshaping() -> None:
    """The same eager declaration (-3 cm) with reshape's default start margin (0.1 m): the capture
    point never gets that far outside the support, so `reshape` never starts and TALOS stays up."""
    row = _reshaped(235, capture_point_margin=-0.03)
    assert 0.1 < row["fall_time"] < 0.3 and row["fall_reason"] == "capture_point"
    assert math.isnan(row["strategy_start_time"]) and row["fell"] is False


def test_a_fall_that_goes_on_is_never_handed_back() -> None:
    row = _reshaped(370)
    assert row["fell"] is True and row["fall_time"] < row["strategy_start_time"] < row["body_contact_time"]
    assert math.isnan(row["hand_back_time"])


def test_free_fall_alone_does_not_start_a_strategy() -> None:
    """A 0.3 m G1 drop that G1 lands on its feet: free fall declares the fall at once, but `reshape`
    waits for a topple (capture point or tilt), so it never acts in the air."""
    scenario = Scenario(name="d", robot="g1", initial={"height": 0.3})
    row = compute_metrics(simulate_named(scenario, "stiff", "reshape"))
    assert row["fall_reason"] == "freefall" and row["fall_time"] < 0.05
    assert not row["strategy_start_time"] < row["impact_time"]  # NaN or after the feet landed
    assert row["fell"] is False


def test_a_fall_an_object_caught_is_a_fall_to_detect() -> None:
    """A robot left leaning on a table is not fallen at rest, but a body other than the feet
    touched: a detector that fired before that touch caught a fall, not a false alarm."""
    runs = _runs()
    runs.loc[2, "body_contact_time"] = 2.5  # the 'false alarm' run (fired at 2.0 s) leans on a table
    row = detection_table(runs).iloc[0]
    assert (row.survived, row.false_alarms, row.fell, row.misses) == (1, 0, 3, 1)
    assert row.lead_median_s == pytest.approx(0.55)  # 0.6 s and 0.5 s
