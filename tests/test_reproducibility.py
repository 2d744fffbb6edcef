"""Bit-identical metrics for the QP-driven policy and strategy (`adaptive_qp`, `reshape`), with either
QP solver, from fresh processes, with 1 or 2 jobs (the fixed-gain policies are covered in
test_runner_store)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pandas as pd
import pytest

from fallbench.results.converge import WALL_CLOCK
from fallbench.results.store import load_metrics

SCENARIOS = """name: qp_drop
duration: 0.6
initial: {height: 1.0}
---
name: qp_push
duration: 1.45           # s: first impact at ~1.4 s
pre_impact: [reshape]
push: {force: 370, duration: 0.1, start: 0.1, direction: 0}
---
name: qp_drop_daqp
duration: 0.6
initial: {height: 1.0}
policy_params: {adaptive_qp: {solver: daqp}}
---
name: qp_push_daqp
duration: 1.45
pre_impact: [reshape]
push: {force: 370, duration: 0.1, start: 0.1, direction: 0}
policy_params: {adaptive_qp: {solver: daqp}, reshape: {solver: daqp}}
"""


def _stored_metrics(command: list[str], results: Path) -> pd.DataFrame:
    """The metrics a sweep in a fresh process stored, without its wall-clock figures."""
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    table = load_metrics(results).set_index("run_id").sort_index()
    assert set(table.status) == {"ok"} and len(table) == 4
    return table[[c for c in table.columns if not WALL_CLOCK.search(c)]]


@pytest.mark.slow
def test_qp_runs_are_bit_identical_across_processes_and_job_counts(tmp_path: Path, sweep) -> None:
    path = tmp_path / "qp.yaml"
    path.write_text(SCENARIOS)

    def swept(folder: str, jobs: int) -> pd.DataFrame:
        results = tmp_path / folder
        return _stored_metrics(sweep.command(path, results, policies="adaptive_qp", jobs=jobs), results)

    first = swept("first", 1)
    for suffix in ("", "_daqp"):
        assert (
            first.loc[first.scenario == "qp_push" + suffix, "preimpact_qp_steps"].iloc[0] > 10
        )  # the reshaping QP ran
        assert (
            first.loc[first.scenario == "qp_drop" + suffix, "qp_steps"].iloc[0] > 10
        )  # the adaptive-gain QP ran
    pd.testing.assert_frame_equal(first, swept("second", 1))
    pd.testing.assert_frame_equal(first, swept("two_jobs", 2))
