"""004 judged where steering can matter: the deflection a fall needs to reach a safe region, forced
candidates for the authority suite, the authority span per push, and the first claim over the hits
whose need lies within it (hand-made rows)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.analysis.safe_regions import SafeRegion, needed_deflection
from fallbench.cli import app
from fallbench.preimpact.direction.candidates import Candidate
from fallbench.preimpact.direction.selection import Forced, choose
from fallbench.report.papers.direction_judge import (
    authority_runs,
    authority_table,
    judge_hits,
    judged_table,
    within_authority_claim,
)
from fallbench.results import store

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def test_needed_deflection_is_the_signed_turn_to_the_nearest_region_edge() -> None:
    regions = [SafeRegion(math.radians(40), math.radians(30))]  # safe from 40 to 70 deg
    assert needed_deflection(math.radians(50), regions) == 0.0
    assert math.degrees(needed_deflection(math.radians(10), regions)) == pytest.approx(30.0)
    assert math.degrees(needed_deflection(math.radians(100), regions)) == pytest.approx(-30.0)
    assert math.degrees(needed_deflection(math.radians(350), regions)) == pytest.approx(50.0)  # across 0
    assert math.isnan(needed_deflection(0.0, []))


def _step(swing: str, offset: tuple[float, float], direction_deg: float) -> Candidate:
    return Candidate(
        "take_step",
        swing,
        np.array(offset),
        SQUARE,
        direction=math.radians(direction_deg),
        step=np.array(offset),
    )


def test_a_forced_step_is_the_one_nearest_the_asked_length_and_bearing() -> None:
    no_action = Candidate("no_action", None, None, SQUARE, direction=math.radians(90))  # falls toward +y
    steps = [_step("left", (0.0, 0.45), 95), _step("left", (-0.3, 0.3), 120), _step("right", (0.3, 0.3), 60)]
    regions = [SafeRegion(0.0, 2 * math.pi)]
    plan = choose([no_action, *steps], regions, mode="take_step", forced=Forced("", 0.45, -45.0))
    assert plan.chosen is steps[2]  # 45 deg clockwise of +y is (+x, +y)
    plan = choose([no_action, *steps], regions, mode="take_step", forced=Forced("", 0.45, 45.0))
    assert plan.chosen is steps[1]
    lift = [Candidate("lift_leg", side, None, SQUARE, direction=0.0) for side in ("left", "right")]
    plan = choose([no_action, *lift], regions, mode="lift_leg", forced=Forced("right"))
    assert plan.chosen.swing == "right"


def _authority_rows() -> pd.DataFrame:
    cell = {
        "robot": "talos",
        "force": 400.0,
        "push_direction": 0.0,
        "scenario": "dir_authority",
        "status": "ok",
        "obstacle_hit": False,
        "obstacle_clearance_at_impact": 2.0,  # m: objects out of reach, the authority suite's free space
    }
    rows = [
        cell
        | {
            "pre_impact": "none",
            "actual_fall_direction_deg": 350.0,
            "impact_fall_direction_deg": 345.0,
            "actual_fall_end": "touchdown",
        }
    ]
    for strategy, deg, at_impact, end in [
        ("no_action", 352.0, 346.0, "touchdown"),
        ("lift_leg_left", 20.0, 355.0, "touchdown"),  # +30 deg, +10 at the first impact (then rolled)
        ("take_step_right", 330.0, 335.0, "touchdown"),  # -20 deg, -10 at the first impact
        ("take_step_left", 90.0, 80.0, "run_end"),  # stayed up: no direction
    ]:
        rows.append(
            cell
            | {
                "pre_impact": "direction",
                "direction_strategy": strategy,
                "actual_fall_direction_deg": deg,
                "impact_fall_direction_deg": at_impact,
                "actual_fall_end": end,
            }
        )
    return pd.DataFrame(rows)


def test_authority_spans_the_deflections_of_the_candidates_that_fell() -> None:
    table = authority_table(authority_runs(_authority_rows(), results=None)).iloc[0]  # type: ignore[arg-type]
    assert table["min deflection (deg)"] == -20.0 and table["max deflection (deg)"] == 30.0
    assert table["lift_leg"] == "+30..+30" and table["stayed up"] == 1
    assert table["min at impact (deg)"] == -10.0 and table["max at impact (deg)"] == 10.0


def test_the_first_claim_is_judged_over_hits_whose_need_is_within_authority() -> None:
    table = authority_table(authority_runs(_authority_rows(), results=None))  # type: ignore[arg-type]
    pairs = pd.DataFrame(
        {
            "scenario": "dir_x",
            "none_hit": [True, True, True, False],
            "direction_hit": [False, True, True, False],
            "need_deg": [25.0, -15.0, 60.0, 0.0],  # within, within, beyond, (clear)
            "robot": "talos",
            "force": [390.0, 420.0, 400.0, 400.0],
            "push_direction": [10.0, 350.0, 0.0, 0.0],
            "none_run_id": ["a", "b", "c", "d"],
        }
    )
    hits = judge_hits(pairs, results=None, table=table)  # type: ignore[arg-type]
    assert hits.within_authority.tolist() == [True, True, False]
    assert hits.within_impact_authority.tolist() == [False, False, False]  # -10..+10 at the first impact
    row = judged_table(pairs, hits).iloc[0]
    assert row["hits within authority"] == 2 and row["avoided, within authority"] == "1/2 (50 %)"
    assert row["avoided, within authority at first impact"] == "-"
    assert (
        row["avoided, all hits"] == "1/3 (33 %)"
        and row["need <= 15 / 15-30 / 30-45 / > 45 deg"] == "1 / 1 / 0 / 1"
    )


def test_a_sweeps_direction_variants_are_judged_apart() -> None:
    """Two settings of one scenario (a swept `when_none_safe`): one row and one claim each."""
    table = authority_table(authority_runs(_authority_rows(), results=None))  # type: ignore[arg-type]
    pairs = pd.DataFrame(
        {
            "scenario": "dir_x",
            "settings": ["when_none_safe=best"] * 2 + ["when_none_safe=no_action"] * 2,
            "none_hit": [True, False, True, False],
            "direction_hit": [False, True, True, False],
            "need_deg": [25.0, 0.0, 25.0, 0.0],
            "robot": "talos",
            "force": 400.0,
            "push_direction": 0.0,
            "none_run_id": ["a", "b", "a", "b"],
        }
    )
    hits = judge_hits(pairs, results=None, table=table)  # type: ignore[arg-type]
    rows = judged_table(pairs, hits).set_index("settings")
    assert rows.loc["when_none_safe=best", "avoided, within authority"] == "1/1 (100 %)"
    assert rows.loc["when_none_safe=best", "clear kept clear"] == "0/1 (0 %)"
    assert rows.loc["when_none_safe=no_action", "avoided, within authority"] == "0/1 (0 %)"
    assert rows.loc["when_none_safe=no_action", "clear kept clear"] == "1/1 (100 %)"
    claims = within_authority_claim(hits)
    assert [c["N/M"][:3] for c in claims] == ["1/1", "0/1"] and "(when_none_safe=best)" in claims[0][
        "claim (004)"
    ]
    assert "settings" not in judged_table(pairs.drop(columns="settings"), hits.drop(columns="settings"))


def test_claims_of_predictors_that_simulate_say_they_are_not_real_time() -> None:
    hits = pd.DataFrame(
        {
            "predictor": ["pendulum", "rollout", "oracle"],
            "within_authority": True,
            "within_impact_authority": [True, False, True],
            "direction_hit": [True, False, False],
        }
    )
    claims = {row["claim (004)"]: row["N/M"] for row in within_authority_claim(hits)}
    labelled = [text for text in claims if "not real time" in text]  # not the pendulum's
    assert len(labelled) == 2
    assert any("rollout prediction" in text for text in labelled)
    assert any("oracle prediction" in text for text in labelled)


def test_capture_prefer_takes_the_step_with_the_widest_capture_margin() -> None:
    no_action = Candidate("no_action", None, None, SQUARE, direction=0.0)
    steps = [_step("left", (0.0, 0.3), 90), _step("right", (0.3, 0.0), 0), _step("left", (0.0, 0.45), 90)]
    steps[0].capture_margin, steps[1].capture_margin, steps[2].capture_margin = 0.02, 0.08, -0.1
    regions = [SafeRegion(0.0, 2 * math.pi)]
    plan = choose([no_action, *steps], regions, capture="prefer")
    assert plan.chosen is steps[1] and plan.inertia_shaping == "" and plan.desired is None
    assert choose([no_action, *steps], regions, capture="off").chosen is no_action  # NA safe: cascade


def test_when_no_candidate_is_safe_the_fallback_is_the_best_score_or_no_action() -> None:
    regions = [SafeRegion(math.radians(80), math.radians(20))]  # safe from 80 to 100 deg only
    no_action = Candidate("no_action", None, None, SQUARE, direction=math.radians(0))
    step = _step("left", (0.0, 0.3), 60)  # nearer the region than No Action, still outside it
    best = choose([no_action, step], regions, when_none_safe="best")
    assert best.chosen is step and best.chosen.score > 1.0 and best.inertia_shaping == "pis"
    fallen = choose([no_action, step], regions, when_none_safe="no_action")
    assert fallen.chosen is no_action and fallen.inertia_shaping == "wbis"  # 004 Fig. 9
    assert (
        choose([no_action, step], regions, selection="argmin", when_none_safe="no_action").chosen is no_action
    )
    safe = _step("left", (0.0, 0.45), 90)  # a safe candidate is taken whatever the fallback
    assert choose([no_action, step, safe], regions, when_none_safe="no_action").chosen is safe


def test_authority_and_radius_commands_fail_cleanly_without_a_store(tmp_path) -> None:
    from typer.testing import CliRunner

    from fallbench.cli import app

    for command in ("authority", "radius"):
        result = CliRunner().invoke(app, ["direction", command, "--results", str(tmp_path / "nothing")])
        assert result.exit_code == 2 and result.output.startswith("error: ")


def _stored(results: Path, rows: list[tuple[dict, dict, pd.DataFrame | None]]) -> None:
    """A small store: (scenario of the spec, metric row, time series or None) per run."""
    for k, (scenario, row, series) in enumerate(rows):
        rid = f"{k:016x}"
        spec = {"scenario": scenario, "policy": "stiff"}
        store.write_run(results, rid, spec, {"run_id": rid, **row}, series, "full")


def test_direction_authority_command_on_a_small_store(tmp_path: Path) -> None:
    results = tmp_path / "r"
    rows = [{k: v for k, v in row.items() if v == v} for row in _authority_rows().to_dict("records")]
    _stored(results, [({"name": "authority"}, row, None) for row in rows])  # `none` has no strategy
    out = tmp_path / "authority.csv"
    result = CliRunner().invoke(app, ["direction", "authority", "--results", str(results), "--out", str(out)])
    assert result.exit_code == 0, result.output
    [row] = pd.read_csv(out).to_dict("records")
    assert (row["min deflection (deg)"], row["max deflection (deg)"]) == (-20.0, 30.0)
    assert (row["min at impact (deg)"], row["max at impact (deg)"]) == (-10.0, 10.0)
    assert row["lift_leg"] == "+30..+30" and row["stayed up"] == 1
    assert result.stdout.startswith("| robot") and "+30..+30" in result.stdout


def test_direction_radius_command_on_a_small_store(tmp_path: Path) -> None:
    """Falls straight ahead (0 deg) from the origin past one cylinder of radius 0.2 m at 2 m ahead
    and 0.5, 0.6 or 0.8 m aside (0.3, 0.4, 0.6 m off the fall's line): two hits, one clear fall; a
    cylinder behind the fall is left out."""
    results = tmp_path / "r"
    series = pd.DataFrame({"t": [0.0, 0.1, 0.2], "com_x": 0.0, "com_y": 0.0})
    runs = []
    for k, (x, y, hit) in enumerate(
        [(2.0, 0.5, True), (2.0, -0.6, True), (2.0, 0.8, False), (-2.0, 0.0, True)]
    ):
        scenario = {
            "name": "bearing",
            "duration": 1.0,
            "obstacles": [{"type": "cylinder", "pos": [x, y, 0.5], "radius": 0.2, "height": 1.0}],
        }
        row = {
            "scenario": "bearing",
            "point": f"bearing#s{k}",
            "policy": "stiff",
            "pre_impact": "none",
            "status": "ok",
            "fall_time": 0.1,
            "actual_fall_direction_deg": 0.0,
            "obstacle_hit": hit,
        }
        runs.append((scenario, row, series))
    _stored(results, runs)
    result = CliRunner().invoke(app, ["direction", "radius", "--results", str(results)])
    assert result.exit_code == 0, result.output
    header, _, line = result.stdout.splitlines()
    cells = dict(
        zip(
            [c.strip() for c in header.strip("|").split("|")], [c.strip() for c in line.strip("|").split("|")]
        )
    )
    assert cells == {
        "robot": "talos",
        "falls": "3",
        "hits": "2",
        "radius (m): widest hit": "0.4",
        "narrowest clear fall (m)": "0.6",
        "clear falls narrower than the radius": "0",
    }
