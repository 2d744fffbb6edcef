"""Runs end at rest: the rest rule on hand-made speeds, the rest posture on hand-made frames, and
whole falls whose measures are read over the run to rest, not changed by a longer cap."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from fallbench.results.converge import WALL_CLOCK, end_ladder, end_table
from fallbench.results.runner import RunSpec, simulate
from fallbench.scenario import Scenario, ScenarioPoint
from fallbench.sim.rest import RestWatch, rest_posture

JOINTS = np.arange(6, 10)  # qvel addresses of four "joints" in the hand-made velocity vectors


def _qvel(linear: float = 0.0, angular: float = 0.0, joint: float = 0.0) -> np.ndarray:
    return np.array([linear, 0, 0, 0, 0, angular, 0, 0, joint, 0], dtype=float)


def _watch(**scenario) -> RestWatch:
    return RestWatch(Scenario(name="t", **scenario), JOINTS)


def test_rest_holds_for_the_hold_time_and_restarts_after_any_motion() -> None:
    watch = _watch(rest={"hold": 0.1})
    times = np.arange(0, 0.4, 0.005)
    # still from 0 to 0.05 s, a joint moves at 0.06 s, still again from 0.065 s on
    speeds = [_qvel(joint=1.0) if math.isclose(t, 0.06) else _qvel(0.09, 0.29, 0.49) for t in times]
    settled_at = next(t for t, qvel in zip(times, speeds) if watch.update(float(t), qvel))
    assert settled_at == pytest.approx(0.165)
    assert watch.time_to_rest == pytest.approx(0.065)


@pytest.mark.parametrize(
    "moving", [_qvel(linear=0.11), _qvel(angular=0.31), _qvel(joint=0.51), _qvel(linear=-0.11)]
)
def test_any_speed_over_its_threshold_is_motion(moving: np.ndarray) -> None:
    watch = _watch(rest={"hold": 0.01})
    assert not any(watch.update(t, moving) for t in np.arange(0, 1, 0.005))
    assert watch.time_to_rest is None


def test_rest_is_only_counted_after_the_push() -> None:
    watch = _watch(rest={"hold": 0.1}, push={"force": 100, "start": 0.2, "duration": 0.1})
    settled_at = next(t for t in np.arange(0, 1, 0.005) if watch.update(float(t), _qvel()))
    assert settled_at == pytest.approx(0.4) and watch.time_to_rest == pytest.approx(0.3)


def _frame(forward, left, up) -> np.ndarray:
    return np.column_stack([forward, left, up]).astype(float)


@pytest.mark.parametrize(
    ("frame", "fell", "posture"),
    [
        (_frame([1, 0, 0], [0, 1, 0], [0, 0, 1]), False, "standing"),
        (_frame([1, 0, 0], [0, 1, 0], [0, 0, 1]), True, "sitting"),
        (_frame([0.6, 0, -0.8], [0, 1, 0], [0.8, 0, 0.6]), False, "leaning"),
        (_frame([0, 0, -1], [0, 1, 0], [1, 0, 0]), True, "lying_front"),
        (_frame([0, 0, 1], [0, 1, 0], [-1, 0, 0]), True, "lying_back"),
        (_frame([1, 0, 0], [0, 0, -1], [0, 1, 0]), True, "lying_side"),
        (_frame([1, 0, 0], [0, 0, 1], [0, -1, 0]), True, "lying_side"),
    ],
)
def test_rest_posture_from_the_torso_axes(frame: np.ndarray, fell: bool, posture: str) -> None:
    assert rest_posture(frame, fell) == posture


def _row(scenario: Scenario, policy: str = "stiff") -> dict:
    outcome = simulate(RunSpec(ScenarioPoint(scenario, {}, "test"), policy), keep_series=False)
    assert outcome.row["status"] == "ok", outcome.row["error"]
    return {k: v for k, v in outcome.row.items() if not WALL_CLOCK.search(k) and k != "run_id"}


@pytest.mark.slow
def test_a_drop_that_tips_over_after_landing_is_recorded_as_a_fall() -> None:
    """TALOS dropped from 0.5 m under stiff lands standing and tips over backwards ~1.5 s in: read
    at rest, the fall and its torso hit are in the row (read at 1.5 s, neither was)."""
    row = _row(Scenario(name="drop", initial={"height": 0.5}))
    assert row["settled"] and 2.0 < row["time_to_rest"] < 6.0
    assert row["fell"] and row["rest_posture"] == "lying_back"
    assert row["contact_force_peak_torso"] > 10_000  # N
    assert row["sim_time"] == pytest.approx(row["time_to_rest"] + 1.0)  # the default 1 s hold


@pytest.mark.slow
def test_twice_the_cap_changes_no_bit_of_a_settled_run() -> None:
    base = Scenario(name="drop", robot="g1", initial={"height": 0.25})
    row = _row(base)
    assert row["settled"]
    longer = _row(base.model_copy(update={"duration": 2 * base.duration}))
    assert [k for k in row if not (row[k] == longer[k] or row[k] != row[k] and longer[k] != longer[k])] == []


def test_a_run_cut_at_its_cap_is_flagged_not_settled() -> None:
    row = _row(Scenario(name="drop", robot="g1", duration=0.3, initial={"height": 0.25}))
    assert row["settled"] is False and math.isnan(row["time_to_rest"])
    assert row["sim_time"] == pytest.approx(0.3)


def _end_runs(capped: dict, held: dict) -> tuple[list, pd.DataFrame, list]:
    """A ladder of hand-made stored rows: as run, twice the cap, twice the hold."""
    point = ScenarioPoint(Scenario(name="t", initial={"height": 0.5}), {}, "t.yaml")
    ladder = end_ladder(point)
    specs = [RunSpec(rung, "stiff") for rung in ladder.levels]
    base = {"status": "ok", "settled": True, "time_to_rest": 2.0, "fell": True, "joint_limit_hits": 3}
    base |= {"contact_force_peak_torso": 1000.0, "wall_time_s": 1.0, "qp_solve_ms_median": 0.1}
    rows = [base, base | capped, base | held]
    frame = pd.DataFrame([row | {"run_id": spec.run_id} for row, spec in zip(rows, specs)])
    return [ladder], frame, specs


def test_the_end_check_wants_identical_bits_with_twice_the_cap() -> None:
    # wall-clock figures may differ; a measure may not, by any amount
    ladders, runs, specs = _end_runs({"wall_time_s": 2.0, "qp_solve_ms_median": 0.3}, {})
    assert end_table(ladders, runs, specs).ok.all()
    ladders, runs, specs = _end_runs({"contact_force_peak_torso": 1000.0 + 1e-9}, {})
    [row] = end_table(ladders, runs, specs).to_dict("records")
    assert not row["ok"] and row["cap_changed"] == "contact_force_peak_torso"


def test_the_end_check_judges_a_longer_hold_on_the_headline_measures() -> None:
    ladders, runs, specs = _end_runs({}, {"contact_force_peak_torso": 1040.0, "time_to_rest": 2.0})
    [row] = end_table(ladders, runs, specs).to_dict("records")
    assert row["ok"] and row["hold_change"] == pytest.approx(0.04)
    ladders, runs, specs = _end_runs({}, {"joint_limit_hits": 4})
    [row] = end_table(ladders, runs, specs).to_dict("records")
    assert not row["ok"] and row["hold_worst"] == "joint_limit_hits"


def test_the_end_check_fails_a_run_that_did_not_settle() -> None:
    ladders, runs, specs = _end_runs({"settled": False}, {})
    runs.loc[0, "settled"] = False
    [row] = end_table(ladders, runs, specs).to_dict("records")
    assert not row["ok"] and not row["settled"]
