"""`fallbench report` and `fallbench results` on a small real store; the claims logic on hand-made rows."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.report.papers.claims import claims_table, verdict_matrix
from fallbench.report.sensitivity import SWEEPS, sensitivity_figure, sensitivity_runs, sensitivity_table

SUITE = """name: drop
rest: {hold: 0.2}
initial: {height: 0.5}
sweep:
  initial.height: [0.5, 1.0]
"""


@pytest.mark.slow
def test_report_writes_figures_tables_and_html(tmp_path: Path, sweep) -> None:
    suite = tmp_path / "drop.yaml"
    suite.write_text(SUITE)
    results, out = tmp_path / "results", tmp_path / "reports"
    run = sweep(suite, results)
    assert run.exit_code == 0, run.output
    result = CliRunner().invoke(
        app, ["report", "--results", str(results), "--out", str(out), "--svg", "--paper-figures", "all"]
    )
    assert result.exit_code == 0, result.output
    for stem in ("fig6a", "fig6b", "fig4"):
        assert len(list(out.glob(f"{stem}_drop_initial_height_1*.png"))) == 1
        assert len(list(out.glob(f"{stem}_drop_initial_height_1*.svg"))) == 1
    assert (out / "sweep_distributions.png").stat().st_size > 10_000
    assert (out / "sweep_drop_initial_height.png").exists()
    page = (out / "index.html").read_text()
    assert "data:image" not in page and "zero reaches the knee" in page and "least damage:" in page
    family = (out / "family_talos_drop.html").read_text()
    assert family.index("drop[initial.height=0.5]") < family.index("drop[initial.height=1]")  # natural order
    assert family.count('<img src="fig6a_') == 2
    assert "| 1 m drop" in (out / "summary.md").read_text()

    listed = CliRunner().invoke(
        app,
        [
            "results",
            "--results",
            str(results),
            "--where",
            "policy == 'zero'",
            "--columns",
            "point,policy,knee_limit_margin",
            "--format",
            "json",
        ],
    )
    assert listed.exit_code == 0, listed.output
    rows = json.loads(listed.output)
    assert len(rows) == 2 and {r["policy"] for r in rows} == {"zero"}
    bad = CliRunner().invoke(app, ["results", "--results", str(results), "--columns", "nope"])
    assert bad.exit_code == 2 and "unknown column" in bad.stderr


def test_report_without_a_store_is_a_clear_error(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["report", "--results", str(tmp_path / "none"), "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 2 and "no results store" in result.stderr


def test_claims_verdicts_follow_the_numbers() -> None:
    rows = pd.DataFrame(
        {
            "scenario": "drop",
            "status": "ok",
            "pre_impact": "none",
            "param:initial.height": 1.0,
            "policy": ["stiff", "oneshot", "zero", "adaptive_qp"],
            "imu_peak_z_landing": [300.0, 200.0, 250.0, 100.0],
            "imu_peak_z": [300.0, 400.0, 250.0, 500.0],  # whole episode: the later fall, not judged
            "knee_limit_margin": [0.5, -0.01, -0.02, 0.3],
            "torque_demand_ratio_landing": [5.0, 0.0, 0.0, 0.9],
            "torque_demand_ratio_max": [5.0, 0.5, 0.4, 3.0],
            "torque_ratio_max": [1.0, 0.5, 0.4, 0.9],
        }
    )
    table = claims_table(rows)
    assert set(table.verdict[:7]) == {"holds"} and set(table["points holding"][:7]) == {"1/1"}
    rows.loc[rows.policy == "adaptive_qp", "knee_limit_margin"] = -0.1
    rows.loc[rows.policy == "adaptive_qp", "imu_peak_z_landing"] = 301.0
    table = claims_table(rows).set_index("claim")
    assert table.loc["adaptive_qp stays off the knee stop", "verdict"].iloc[0] == "does not hold"
    assert table.loc["adaptive_qp stays off the knee stop", "points holding"].iloc[0] == "0/1"
    assert (
        table.loc["adaptive_qp has a lower IMU acceleration than stiff (landing)", "verdict"].iloc[0]
        == "does not hold"
    )
    assert (
        "whole episode stiff 300.0, oneshot 400.0, zero 250.0, adaptive_qp 500.0"
        in table.loc["stiff has the highest IMU acceleration (landing)", "numbers"].iloc[0]
    )


def test_claims_per_baseline_gain_scale() -> None:
    """A sensitivity sweep gets one scope per (gain scale, adaptive_qp setting); the drops' scopes keep scale 1."""
    scales, settings = [0.5, 0.5, 2.0, 2.0], [100.0, 25.0, 100.0, 25.0]
    rows = pd.DataFrame(
        [
            {
                "scenario": "sensitivity",
                "status": "ok",
                "pre_impact": "none",
                "policy": policy,
                "param:policy_params.stiff.gain_scale": scale,
                "param:policy_params.adaptive_qp.posture_kp": kp,
                "imu_peak_z_landing": {"stiff": 100.0 * scale, "adaptive_qp": 150.0}[policy],
                "imu_peak_z": 300.0,
                "knee_limit_margin": 0.3,
                "torque_demand_ratio_landing": 0.5,
                "torque_demand_ratio_max": 0.5,
                "torque_ratio_max": 0.5,
            }
            for scale, kp in zip(scales, settings)
            for policy in ("stiff", "adaptive_qp")
        ]
    )
    other_robot = rows.iloc[:2].assign(
        robot="g1", scenario="drop", **{"param:policy_params.stiff.gain_scale": float("nan")}
    )
    rows = pd.concat([rows.assign(robot="talos"), other_robot], ignore_index=True)
    rows = rows.astype({"policy": "string[pyarrow]", "robot": "string[pyarrow]"})  # as the store reads them
    table = claims_table(rows)
    lower = table[
        (table["claim"] == "adaptive_qp has a lower IMU acceleration than stiff (landing)")
        & (table.robot == "talos")
    ]
    assert dict(zip(lower.scope, lower.verdict)) == {
        "sensitivity: gain scale 0.5, adaptive_qp.posture_kp=25": "does not hold",
        "sensitivity: gain scale 0.5, adaptive_qp.posture_kp=100": "does not hold",
        "sensitivity: gain scale 2, adaptive_qp.posture_kp=25": "holds",
        "sensitivity: gain scale 2, adaptive_qp.posture_kp=100": "holds",
    }


def test_first_impact_table_counts_by_push_direction() -> None:
    from fallbench.report.papers.reshape import first_impact_table, push_label

    rows = pd.DataFrame(
        {
            "scenario": "push_200N",
            "status": "ok",
            "param:push.direction": [0, 0, 180, 180, 180],
            "pre_impact": ["none", "reshape", "none", "reshape", "reshape"],
            "first_impact_group": ["knees", "hands", "torso", "hands", "knees+feet"],
            "first_impact_safe": [False, True, False, True, False],
            "contact_force_peak_head": [100.0, 50.0, 0.0, 0.0, 10.0],
            "contact_force_peak_torso": [1.0, 2.0, 3.0, 4.0, 6.0],
            "time_to_first_impact": [0.5, 0.4, 0.7, 0.6, 0.8],
        }
    )
    table = first_impact_table(rows).set_index(["push", "pre_impact"])
    assert table.loc[("back", "reshape"), "falls"] == 2
    assert table.loc[("back", "reshape"), "first on hands/feet (%)"] == 50
    assert table.loc[("back", "reshape"), "first on knees (%)"] == 50
    assert table.loc[("back", "none"), "first on torso/head (%)"] == 100
    assert table.loc[("back", "reshape"), "torso peak median (N)"] == 5
    assert table.loc[("front", "none"), "first on knees (%)"] == 100
    assert [push_label(d) for d in (0, 45, 90, 180, 225, -90)] == [
        "front",
        "front diagonal",
        "side",
        "back",
        "back diagonal",
        "side",
    ]


def test_sensitivity_lines_table_and_figure(tmp_path: Path) -> None:
    """One line per policy and per adaptive_qp setting; other policies' repeats share their line."""
    rows = pd.DataFrame(
        [
            {
                "scenario": "sensitivity",
                "status": "ok",
                "pre_impact": "none",
                "policy": policy,
                "param:policy_params.stiff.gain_scale": scale,
                "param:policy_params.adaptive_qp.posture_kp": kp,
                "imu_peak_z_landing": scale * (10.0 if policy == "stiff" else kp),
                "imu_peak_z": 1.0,
                "knee_limit_margin": 0.1,
                "torque_demand_ratio_landing": 0.5,
                "qp_failures_landing": 0,
                "fell": policy == "stiff",
            }
            for scale in (1.0, 2.0)
            for kp in (100, 25)
            for policy in ("stiff", "adaptive_qp")
        ]
    )
    swept = sensitivity_runs(rows)
    assert set(swept.line) == {"stiff", "adaptive_qp, posture_kp=100", "adaptive_qp, posture_kp=25"}
    table = sensitivity_table(swept).set_index(["gain_scale", "line"])  # the sweep's name heads the column
    assert table.loc[(2.0, "adaptive_qp, posture_kp=25"), "imu_peak_z_landing"] == 50.0
    assert (
        table.loc[(2.0, "stiff"), "imu_peak_z_landing"] == 20.0 and table.loc[(2.0, "stiff"), "fell"] == 1.0
    )
    paths = sensitivity_figure(swept, tmp_path)
    assert [p.name for p in paths] == ["sensitivity_gain_scale.png"]  # SVG only with `--svg`
    assert paths[0].stat().st_size > 10_000
    softness = SWEEPS[1]
    contact = rows.drop(columns=["param:policy_params.stiff.gain_scale"]).assign(
        **{softness.column: [0.0125, 0.05] * (len(rows) // 2)}
    )
    table = sensitivity_table(sensitivity_runs(contact, softness), softness)
    assert list(table.columns[:2]) == ["contact_time_constant", "line"]
    assert sorted(table.contact_time_constant.unique()) == [0.0125, 0.05]
    paths = sensitivity_figure(sensitivity_runs(contact, softness), tmp_path, softness)
    assert paths[0].name == "sensitivity_contact_time_constant.png"


def test_prescription_and_detection_tables_on_hand_made_rows() -> None:
    from fallbench.report.papers.reshape import detection_table, prescription_table

    nan = float("nan")
    rows = pd.DataFrame(
        {
            "scenario": "push_x",
            "status": "ok",
            "param:push.direction": [0.0, 0.0, 90.0, 270.0, 0.0],  # deg: pushes at set directions
            "first_impact_group": ["knees", "knees", "hands", "hands", ""],
            "pre_impact": ["none", "reshape", "none", "reshape", "none"],
            "fall_class": ["front", "front", "left", "right", ""],
            "first_impact_prescribed": [True, False, False, True, False],
            "knees_simultaneous": [1.0, 0.0, nan, nan, nan],
            "head_before_hands": [False, True, False, False, False],
            "contact_force_peak_head": [20000.0, 8000.0, 7000.0, 0.0, 0.0],
            "contact_force_peak_torso": [1.0, 2.0, 3.0, 4.0, 0.0],
            "imu_peak_norm": 100.0,
            "imu_peak_z_5ms": 50.0,
            "fall_lead_time": [1.2, 1.1, 1.0, 0.9, nan],
            "fall_reason": "capture_point",
            "fall_lead_time_capture_point": [1.2, 1.1, 1.0, 0.9, nan],
            "fall_lead_time_tilt": [0.6, 0.5, nan, 0.4, nan],
            "fall_lead_time_freefall": nan,
        }
    )
    table = prescription_table(rows).set_index(["fall", "pre_impact"])
    assert (
        table.loc[("front", "none"), "prescribed (%)"] == 100
        and table.loc[("front", "reshape"), "knees together"] == "0/1"
    )
    assert (
        table.loc[("side", "reshape"), "prescribed (%)"] == 100
        and table.loc[("side", "none"), "head peak median (N)"] == 7000
    )
    assert (
        table.loc[("front", "reshape"), "head before hands (%)"] == 100 and len(table) == 4
    )  # the run that did not fall is left out
    detection = detection_table(rows).set_index("fall")
    assert (
        detection.loc["front", "capture_point lead median (s)"] == 1.2
        and detection.loc["side", "tilt fired (%)"] == 0
    )


def test_verdict_matrix_has_one_row_per_scope() -> None:
    claims = pd.DataFrame(
        {
            "robot": "talos",
            "scope": ["1 m drop", "1 m drop", "all drops"],
            "claim": [
                "stiff stays off the knee stop",
                "zero reaches the knee's mechanical stop",
                "stiff stays off the knee stop",
            ],
            "verdict": ["holds", "does not hold", "holds"],
            "numbers": "",
        }
    )
    matrix = verdict_matrix(claims).set_index("scope")
    assert list(matrix.columns) == ["robot", "stiff: off the stop", "zero: at the stop"]
    assert matrix.loc["1 m drop", "zero: at the stop"] == "does not hold" and pd.isna(
        matrix.loc["all drops", "zero: at the stop"]
    )


def test_newest_run_of_each_fall_is_kept_by_its_stored_time(tmp_path: Path) -> None:
    """Two rows of one fall (a sweep run again after a code change): the one stored last is kept,
    whatever its id; a different fall is untouched."""
    import os

    from fallbench.report.grouping import newest_runs

    key = {"robot": "talos", "scenario": "drop", "point": "drop#s0", "seed": 0, "pre_impact": "none"}
    runs = pd.DataFrame(
        [
            key | {"run_id": "aaa", "policy": "stiff", "imu_peak_z": 1.0},  # stored last
            key | {"run_id": "bbb", "policy": "stiff", "imu_peak_z": 2.0},  # stored first
            key | {"run_id": "ccc", "policy": "zero", "imu_peak_z": 3.0},
        ]
    )
    for rid, stored in (("aaa", 2_000_000), ("bbb", 1_000_000), ("ccc", 1_000_000)):
        folder = tmp_path / "runs" / rid
        folder.mkdir(parents=True)
        (folder / "metrics.json").write_text("{}")
        os.utime(folder / "metrics.json", (stored, stored))
    kept, set_aside = newest_runs(runs, tmp_path)
    assert set_aside == 1 and kept.run_id.tolist() == ["aaa", "ccc"]
    assert newest_runs(runs.iloc[[0, 2]], tmp_path)[1] == 0


@pytest.mark.slow
def test_report_of_a_store_holding_a_fall_twice_uses_the_newest(tmp_path: Path, sweep) -> None:
    """A store where each fall of one policy was stored again under a new id (as after a code
    change) gives a report; the newer runs' numbers are the ones shown, and the opening line says
    how many older ones were set aside."""
    import os
    import shutil

    from fallbench.results import store

    suite = tmp_path / "drop.yaml"
    suite.write_text(SUITE)
    results, out = tmp_path / "results", tmp_path / "reports"
    assert sweep(suite, results).exit_code == 0
    for rid in store.load_metrics(results).query("policy == 'zero'").run_id:
        again = store.run_dir(results, f"{rid}v2")
        shutil.copytree(store.run_dir(results, rid), again)
        stored = json.loads((again / "metrics.json").read_text())
        stored["metrics"] |= {"run_id": again.name, "knee_limit_margin": 12345.0}
        (again / "metrics.json").write_text(json.dumps(stored))
        later = (again / "metrics.json").stat().st_mtime + 60
        os.utime(again / "metrics.json", (later, later))
    store.consolidate(results)
    assert len(store.load_metrics(results)) == 6
    result = CliRunner().invoke(app, ["report", "--results", str(results), "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    assert "4 runs; 2 older run(s) of a fall stored again set aside" in (out / "index.html").read_text()
    summary = (out / "summary.md").read_text()
    assert "2 older run(s)" in summary.splitlines()[2] and "12345" in summary


def test_runs_that_did_not_settle_are_left_out_and_counted(tmp_path: Path) -> None:
    """none + zero is gentler than none + stiff only in its two runs still moving at their cap:
    left out, they change no verdict, and the overview and the family page count them."""
    from fallbench.report import build_report
    from fallbench.results import store

    results, out = tmp_path / "results", tmp_path / "reports"
    for k in range(4):
        for policy, head in (("stiff", 500.0), ("zero", 600.0 if k < 2 else 1.0)):
            run_id = f"{policy}{k}"
            row = {
                "run_id": run_id,
                "robot": "talos",
                "scenario": "fam",
                "point": f"fam#s{k}",
                "seed": k,
                "status": "ok",
                "error": "",
                "pre_impact": "none",
                "policy": policy,
                "contact_force_peak_head": head + k,
                "imu_peak_z": 100.0,
                "knee_limit_margin": 0.3,
                "torque_demand_ratio_max": 1.0,
                "contact_force_peak": 2000.0,
                "joint_limit_hits": 0,
                "first_impact_group": "hands",
                "first_impact_safe": True,
                "obstacle_force_peak": 0.0,
                "time_to_first_impact": 0.5,
                "impact_time": 0.5,
                "landing_error": float("nan"),
                "contact_force_peak_bw": 2.0,
                "contact_force_peak_torso": 500.0,
                "vulnerable_hits": 0,
                "fell": True,
                "settled": policy == "stiff" or k < 2,
            }
            store.write_run(results, run_id, {"point": row["point"]}, row, None)
    store.consolidate(results)
    build_report(results, out, progress=False)
    index, family = (out / "index.html").read_text(), (out / "family_talos_fam.html").read_text()
    assert "6 runs; 2 runs did not settle by their cap, left out from" in index
    assert "names the unprotected fall (none + stiff) least damage: talos 1 of 1 (ties: 0)." in index
    assert (
        "6 runs over 4 points (sweep values x seeds); 2 runs did not settle by their cap, left out." in family
    )
    for page in (index, family):
        assert "least damage: none + stiff" in page and "none + zero (mean rank" not in page


def test_a_store_without_settled_counts_every_run_as_settled() -> None:
    from fallbench.report.grouping import settled_runs

    runs = pd.DataFrame({"run_id": ["a", "b"], "status": ["ok", "ok"]})
    kept, unsettled = settled_runs(runs)
    assert list(kept.run_id) == ["a", "b"] and unsettled.empty
    kept, unsettled = settled_runs(runs.assign(settled=[True, False]))
    assert list(kept.run_id) == ["a"] and list(unsettled.run_id) == ["b"]


def test_a_store_whose_runs_never_settled_reports_what_it_can(tmp_path: Path, sweep) -> None:
    """Every run cut at its cap (a 0.3 s drop): nothing to rank, and the report says so, not fails."""
    suite = tmp_path / "cut.yaml"
    suite.write_text("name: cut\nduration: 0.3\ninitial: {height: 0.5}\n")
    results, out = tmp_path / "results", tmp_path / "reports"
    assert sweep(suite, results, policies="stiff,zero").exit_code == 0
    result = CliRunner().invoke(app, ["report", "--results", str(results), "--out", str(out), "--jobs", "1"])
    assert result.exit_code == 0, result.output
    assert "2 runs did not settle by their cap, left out" in (out / "index.html").read_text()
