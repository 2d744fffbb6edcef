"""`--backend dask`: a tiny sweep on a LocalCluster gives the local backend's results, and a resumed
sweep simulates only the runs missing from the store."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest

from fallbench.results.store import load_metrics

SUITE = """name: drop
duration: 0.6
initial: {height: 0.3}
sweep:
  initial.height: [0.3, 0.6]
"""
COLUMNS = ["run_id", "status", "imu_peak_z", "knee_limit_margin", "torque_ratio_max", "contact_force_peak"]


def _stored_files(results: Path) -> dict[str, tuple[int, int]]:
    """Size and modification time of every run file and consolidated part of the store."""
    files = [*(results / "runs").rglob("*"), *(results / "metrics").glob("part-*.parquet")]
    return {
        str(f.relative_to(results)): (f.stat().st_size, f.stat().st_mtime_ns) for f in files if f.is_file()
    }


def _metrics(results: Path) -> pd.DataFrame:
    return load_metrics(results)[COLUMNS].sort_values("run_id").reset_index(drop=True)


@pytest.mark.slow
def test_dask_local_cluster_matches_loky_and_resumes(tmp_path: Path, sweep) -> None:
    path = tmp_path / "drop.yaml"
    path.write_text(SUITE)
    local = sweep(path, tmp_path / "loky", "--backend", "loky", jobs=2)
    assert local.exit_code == 0, local.output
    results = tmp_path / "dask"
    first = sweep(path, results, "--backend", "dask", jobs=2)
    assert first.exit_code == 0, first.output
    assert len(first.simulated) == len(set(first.simulated)) == 4
    expected = _metrics(tmp_path / "loky")
    pd.testing.assert_frame_equal(_metrics(results), expected)
    assert sorted(first.simulated) == list(expected.run_id)

    # a sweep killed before its last run and before consolidating: three run folders, no table
    missing = first.simulated[-1]
    shutil.rmtree(results / "runs" / missing)
    shutil.rmtree(results / "metrics")
    resumed = sweep(path, results, "--backend", "dask")
    assert resumed.exit_code == 0, resumed.output
    assert resumed.simulated == (missing,)  # the three stored runs are not simulated again
    pd.testing.assert_frame_equal(_metrics(results), expected)  # one row per run, the same values
    assert "\n4 runs in " in resumed.output

    before = _stored_files(results)
    again = sweep(path, results, "--backend", "dask")  # everything stored: nothing runs, nothing is written
    assert again.exit_code == 0, again.output
    assert again.simulated == ()
    assert _stored_files(results) == before
    assert "\n4 runs in " in again.output and "0 failed" in again.output
    pd.testing.assert_frame_equal(_metrics(results), expected)


def test_scheduler_without_dask_backend_is_rejected(tmp_path: Path, sweep) -> None:
    path = tmp_path / "drop.yaml"
    path.write_text(SUITE)
    result = sweep(path, tmp_path / "r", "--scheduler", "tcp://127.0.0.1:8786")
    assert result.exit_code == 2
    assert "--scheduler needs --backend dask" in result.stderr
    assert result.simulated == () and not (tmp_path / "r").exists()
