"""`--backend dask`: a tiny sweep on a LocalCluster gives the local backend's results and resumes."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results.store import load_metrics

SUITE = """name: drop
duration: 0.6
initial: {height: 0.3}
sweep:
  initial.height: [0.3, 0.6]
"""
COLUMNS = ["run_id", "status", "imu_peak_z", "knee_limit_margin", "torque_ratio_max", "contact_force_peak"]


def _sweep(path: Path, results: Path, *backend: str):
    return CliRunner().invoke(
        app,
        [
            "run",
            "sweep",
            str(path),
            "--results",
            str(results),
            "--reports",
            str(results / "rep"),
            "--policies",
            "stiff,zero",
            "--pre-impact",
            "none",
            "--jobs",
            "2",
            *backend,
        ],
    )


def test_dask_local_cluster_matches_loky_and_resumes(tmp_path: Path) -> None:
    path = tmp_path / "drop.yaml"
    path.write_text(SUITE)
    assert _sweep(path, tmp_path / "loky").exit_code == 0
    result = _sweep(path, tmp_path / "dask", "--backend", "dask")
    assert result.exit_code == 0, result.output
    local = load_metrics(tmp_path / "loky")[COLUMNS].sort_values("run_id").reset_index(drop=True)
    dask = load_metrics(tmp_path / "dask")[COLUMNS].sort_values("run_id").reset_index(drop=True)
    assert len(dask) == 4
    pd.testing.assert_frame_equal(local, dask)
    again = _sweep(path, tmp_path / "dask", "--backend", "dask")  # everything stored: nothing runs again
    assert again.exit_code == 0 and "4 runs" in again.output
    assert len(list((tmp_path / "dask" / "runs").iterdir())) == 4


def test_scheduler_without_dask_backend_is_rejected(tmp_path: Path) -> None:
    path = tmp_path / "drop.yaml"
    path.write_text(SUITE)
    result = _sweep(path, tmp_path / "r", "--scheduler", "tcp://127.0.0.1:8786")
    assert result.exit_code == 2
    assert "--scheduler needs --backend dask" in result.stderr
