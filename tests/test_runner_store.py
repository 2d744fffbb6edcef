"""Sweeps: stored failures, resume after a kill, determinism across job counts, scene export."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import pandas as pd
import pyarrow.parquet as pq
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results.store import load_metrics

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


def _sweep(path: Path, results: Path, jobs: int, *extra: str):
    return CliRunner().invoke(
        app,
        [
            "run",
            "sweep",
            str(path),
            "--results",
            str(results),
            "--jobs",
            str(jobs),
            "--policies",
            "stiff,zero",
            "--pre-impact",
            "none",
            "--reports",
            str(results / "rep"),
            *extra,
        ],
    )


def test_failures_are_stored_and_strict_exits_nonzero(tmp_path: Path) -> None:
    path = _write(tmp_path)
    result = _sweep(path, tmp_path / "r", 1)
    assert result.exit_code == 0, result.output
    table = load_metrics(tmp_path / "r")
    assert len(table) == 8 and table.run_id.is_unique
    assert set(table[table.scenario == "boom"].status) == {"diverged"}
    assert set(table[table.scenario == "tiny"].status) == {"ok"}
    strict = _sweep(path, tmp_path / "r", 1, "--strict")
    assert strict.exit_code == 1
    assert "0 failed" not in strict.output and "2 failed or diverged" in strict.output


def test_same_metrics_with_one_or_two_jobs(tmp_path: Path) -> None:
    path = _write(tmp_path)
    assert _sweep(path, tmp_path / "one", 1).exit_code == 0
    assert _sweep(path, tmp_path / "two", 2).exit_code == 0
    one = load_metrics(tmp_path / "one").set_index("run_id").sort_index()
    two = load_metrics(tmp_path / "two").set_index("run_id").sort_index()
    ok = one.status == "ok"
    pd.testing.assert_frame_equal(one.loc[ok, DETERMINISTIC], two.loc[ok, DETERMINISTIC])


def _finished(results: Path) -> int:
    runs = results / "runs"
    return len(list(runs.glob("[!.]*"))) if runs.exists() else 0


def _killed_sweep(path: Path, results: Path, sig: int) -> None:
    cmd = [
        sys.executable,
        "-m",
        "fallbench.cli",
        "run",
        "sweep",
        str(path),
        "--results",
        str(results),
        "--jobs",
        "1",
        "--policies",
        "stiff,oneshot,zero",
        "--pre-impact",
        "none",
        "--reports",
        str(results / "rep"),
        "--no-progress",
    ]
    # SIGINT back to its default in the child: a shell's background job inherits it ignored, and
    # the sweep would then run to the end whatever the test sends
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.time() + 120
    while time.time() < deadline and _finished(results) < 2:
        time.sleep(0.05)
    proc.send_signal(sig)
    proc.wait(timeout=60)


def test_killed_sweep_resumes_without_duplicates(tmp_path: Path) -> None:
    path = _write(tmp_path)
    for sig in (signal.SIGKILL, signal.SIGINT):
        results = tmp_path / f"r{int(sig)}"
        _killed_sweep(path, results, sig)
        done_before = {p.name for p in (results / "runs").iterdir() if not p.name.startswith(".")}
        assert 0 < len(done_before) < 12
        for folder in (results / "runs").iterdir():  # every complete folder is readable
            if not folder.name.startswith("."):
                pq.read_table(folder / "metrics.parquet")
        result = CliRunner().invoke(
            app,
            [
                "run",
                "sweep",
                str(path),
                "--results",
                str(results),
                "--jobs",
                "1",
                "--policies",
                "stiff,oneshot,zero",
                "--pre-impact",
                "none",
                "--reports",
                str(results / "rep"),
            ],
        )
        assert result.exit_code == 0, result.output
        table = load_metrics(results)
        assert len(table) == 12 and table.run_id.is_unique
        assert done_before <= set(table.run_id)


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
    assert model.nu == 32 and model.nkey == 1 and model.sensor("imu_acc") is not None
    os.remove(scene)
