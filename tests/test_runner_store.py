"""Sweeps: stored failures, resume after a kill, determinism across job counts, scene export."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import mujoco
import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results import store
from fallbench.results.store import load_metrics
from fallbench.robots import get_robot

SMALL = """name: tiny
duration: 0.6
initial: {height: 0.3}
sweep:
  initial.height: [0.1, 0.2, 0.3]
---
name: boom                # the largest push on the lightest body at the coarsest step: diverges after 0.2 s
duration: 0.3
physics_dt: 0.01
control_dt: 0.01
contact: {time_constant: 0.02, stop_time_constant: 0.02}
push: {force: 10000, duration: 0.1, start: 0.0, body: gripper_left_fingertip_1_link}
"""
DETERMINISTIC = [
    "imu_peak_z",
    "imu_peak_norm_5ms",
    "knee_limit_margin",
    "torque_ratio_max",
    "contact_force_peak",
    "impact_time",
]


def _write(tmp_path: Path) -> Path:
    path = tmp_path / "small.yaml"
    path.write_text(SMALL)
    return path


def test_failures_are_stored_and_strict_exits_nonzero(tmp_path: Path, sweep) -> None:
    path = _write(tmp_path)
    result = sweep(path, tmp_path / "r")
    assert result.exit_code == 0, result.output
    table = load_metrics(tmp_path / "r")
    assert len(table) == 8 and table.run_id.is_unique
    assert set(table[table.scenario == "boom"].status) == {"diverged"}
    assert set(table[table.scenario == "tiny"].status) == {"ok"}
    strict = sweep(path, tmp_path / "r", "--strict")
    assert strict.exit_code == 1 and strict.simulated == ()  # stored failures are reported, not run again
    assert "0 failed" not in strict.output and "2 failed or diverged" in strict.output


def test_a_sweep_whose_every_run_fails_is_summarised(tmp_path: Path, sweep, monkeypatch) -> None:
    """Runs stored with status `error` and no metric columns still give the summary and its count."""
    from fallbench.analysis import metrics

    def broken(*arguments):
        raise RuntimeError("planted")

    monkeypatch.setattr(metrics, "compute_metrics", broken)
    path = tmp_path / "one.yaml"
    path.write_text("name: tiny\nduration: 0.3\n")
    result = sweep(path, tmp_path / "r")
    assert result.exit_code == 0, result.output
    assert "2 runs in" in result.output and "2 failed or diverged" in result.output  # stiff, zero
    assert "RuntimeError: planted" in result.output


def test_same_metrics_with_one_or_two_jobs(tmp_path: Path, sweep) -> None:
    path = _write(tmp_path)
    assert sweep(path, tmp_path / "one", jobs=1).exit_code == 0
    assert sweep(path, tmp_path / "two", jobs=2).exit_code == 0
    one = load_metrics(tmp_path / "one").set_index("run_id").sort_index()
    two = load_metrics(tmp_path / "two").set_index("run_id").sort_index()
    ok = one.status == "ok"
    pd.testing.assert_frame_equal(one.loc[ok, DETERMINISTIC], two.loc[ok, DETERMINISTIC])


def _finished(results: Path) -> int:
    runs = results / "runs"
    return len(list(runs.glob("[!.]*"))) if runs.exists() else 0


def _killed_sweep(command: list[str], results: Path, sig: int) -> None:
    # SIGINT back to its default in the child: a shell's background job inherits it ignored, and
    # the sweep would then run to the end whatever the test sends
    proc = subprocess.Popen(
        command,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.time() + 120
    while time.time() < deadline and _finished(results) < 2:
        time.sleep(0.05)
    proc.send_signal(sig)
    proc.wait(timeout=60)


@pytest.mark.slow
def test_killed_sweep_resumes_without_duplicates(tmp_path: Path, sweep) -> None:
    path = _write(tmp_path)
    policies = "stiff,oneshot,zero"
    for sig in (signal.SIGKILL, signal.SIGINT):
        results = tmp_path / f"r{int(sig)}"
        _killed_sweep(sweep.command(path, results, policies=policies), results, sig)
        done_before = {p.name for p in (results / "runs").iterdir() if not p.name.startswith(".")}
        assert 0 < len(done_before) < 12
        for folder in (results / "runs").iterdir():  # every complete folder is readable
            if not folder.name.startswith("."):
                store.load_run_row(results, folder.name)
        result = sweep(path, results, policies=policies)
        assert result.exit_code == 0, result.output
        table = load_metrics(results)
        assert len(table) == 12 and table.run_id.is_unique
        # the resumed sweep simulates the missing runs, each once, and none of the finished ones
        assert len(result.simulated) == len(set(result.simulated)) == 12 - len(done_before)
        assert set(result.simulated) == set(table.run_id) - done_before


def test_run_one_prints_metrics_and_export_loads_alone(tmp_path: Path) -> None:
    path = _write(tmp_path)
    result = CliRunner().invoke(
        app,
        [
            "run",
            "one",
            str(path),
            "--point",
            "initial.height=0.2",
            "--policy",
            "zero",
            "--results",
            str(tmp_path / "r"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "imu_peak_z" in result.output and "tiny[initial.height=0.2]" in result.output
    ambiguous = CliRunner().invoke(app, ["run", "one", str(path), "--results", str(tmp_path / "r")])
    assert ambiguous.exit_code == 2 and "selects 4 points" in ambiguous.stderr
    scene = tmp_path / "scene.xml"
    result = CliRunner().invoke(app, ["scenarios", "export", str(path), "--point", "1", "--out", str(scene)])
    assert result.exit_code == 0, result.output
    model = mujoco.MjModel.from_xml_path(str(scene))
    assert model.nu == 32 and model.nkey == 1
    accelerometer = model.sensor("imu_acc")  # a 3-axis accelerometer on the IMU site of the IMU body
    assert (accelerometer.type[0], accelerometer.dim[0], accelerometer.objtype[0]) == (
        mujoco.mjtSensor.mjSENS_ACCELEROMETER,
        3,
        mujoco.mjtObj.mjOBJ_SITE,
    )
    imu = model.site(int(accelerometer.objid[0]))
    assert imu.name == "imu" and model.body(int(imu.bodyid[0])).name == get_robot("talos").imu_body
    os.remove(scene)


def test_run_one_exits_1_on_a_diverged_run(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["run", "one", str(_write(tmp_path)), "--point", "3", "--results", str(tmp_path / "r")]
    )
    assert result.exit_code == 1, result.output
    printed = dict(line.split(maxsplit=1) for line in result.stdout.splitlines() if len(line.split()) > 1)
    assert printed["status"] == "diverged" and printed["point"] == "boom#s0"
    assert store.consolidate(tmp_path / "r") == 1
    [stored] = load_metrics(tmp_path / "r").status
    assert stored == "diverged"  # stored all the same
