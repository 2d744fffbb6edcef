"""Results store: incremental consolidation gives the full rebuild's table, an interrupted merge
never duplicates a row, the parts read in DuckDB and pandas, `fallbench results --sql` and filters."""

from __future__ import annotations

import shutil
from pathlib import Path

import duckdb
import pandas as pd
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results import store

POLICIES = ("stiff", "oneshot", "zero", "adaptive_qp")


def _row(i: int) -> dict[str, object]:
    """A metric row with the variety real sweeps give: swept values of different types per
    family, text that is null in some runs, a metric that only some policies have."""
    policy = POLICIES[i % 4]
    row: dict[str, object] = {
        "run_id": f"{i * 7919 % 1000:03d}{i:013d}",
        "scenario": f"family{i % 3}",
        "point": f"p{i}",
        "policy": policy,
        "pre_impact": "none" if i % 5 else "reshape",
        "seed": i,
        "status": "ok" if i % 9 else "error",
        "error": None if i % 9 else "ValueError: boom",
        "imu_peak_z": 100.0 + i,
        "fell": bool(i % 2),
    }
    if i % 3 == 1:
        row["param:push.direction"] = i % 4 * 45 if i < 30 else i * 1.5  # int in early runs, float later
    if policy == "adaptive_qp":
        row["qp_step_ms_median"] = 0.1 * i
    return row


def _add(results: Path, rows: range) -> None:
    for i in rows:
        row = _row(i)
        store.write_run(results, str(row["run_id"]), {"i": i}, row, None)


def _read_all(results: Path) -> pd.DataFrame:
    table = store.load_metrics(results)
    return table[sorted(table.columns)]


def test_incremental_consolidation_equals_full_rebuild(tmp_path: Path) -> None:
    results = tmp_path / "r"
    start, batches = (
        0,
        (1, 1, 1, 2, 1, 1, 1, 1, 1, 5, 9, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 29, 3),
    )  # several merges
    for batch in batches:
        _add(results, range(start, start + batch))
        assert store.consolidate(results) == batch
        start += batch
    assert store.consolidate(results) == 0
    incremental = _read_all(results)
    parts = list((results / "metrics").glob("part-*.parquet"))
    assert (
        len(incremental) == sum(batches) == 67
        and incremental.run_id.is_unique
        and len(parts) <= 2 * (store.FANOUT - 1)
    )
    shutil.copytree(results, tmp_path / "full")
    assert store.consolidate(tmp_path / "full", full=True) == 67
    pd.testing.assert_frame_equal(incremental, _read_all(tmp_path / "full"))
    # what users read directly: DuckDB on the glob, pandas on the folder with the common schema
    glob = str(results / "metrics" / "*.parquet")
    assert (
        duckdb.execute(
            f"SELECT count(DISTINCT run_id) FROM read_parquet('{glob}', union_by_name = true)"
        ).fetchone()[0]
        == 67
    )
    schema = pq.read_schema(results / "metrics" / "_common_metadata")
    direct = pd.read_parquet(results / "metrics", schema=schema).sort_values("run_id").reset_index(drop=True)
    pd.testing.assert_frame_equal(direct[sorted(direct.columns)], incremental)
    swept = incremental.set_index("seed")["param:push.direction"]
    assert (swept[1], swept[4], swept[34]) == (45.0, 0.0, 51.0) and swept.isna().sum() == 45


def test_interrupted_merge_is_finished_without_duplicates(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    results = tmp_path / "r"
    for i in range(store.FANOUT - 1):
        _add(results, range(i, i + 1))
        store.consolidate(results)
    _add(results, range(7, 8))
    calls = {"n": 0}
    recover = store._recover

    def crash_after_journal(table: Path) -> None:
        calls["n"] += 1
        if calls["n"] == 2:  # the merge's own recovery: the process dies right after the journal
            raise KeyboardInterrupt
        recover(table)

    monkeypatch.setattr(store, "_recover", crash_after_journal)
    with pytest.raises(KeyboardInterrupt):
        store.consolidate(results)
    monkeypatch.setattr(store, "_recover", recover)
    assert (results / "metrics" / store.JOURNAL).exists()
    assert len(store.load_metrics(results)) == 8  # readers see the parts before the merge
    assert store.consolidate(results) == 0
    after = store.load_metrics(results)
    assert len(after) == 8 and after.run_id.is_unique
    assert not (results / "metrics" / store.JOURNAL).exists()
    assert not list((results / "metrics").glob(".*"))


def test_results_sql_and_pushed_down_filters(tmp_path: Path) -> None:
    results = tmp_path / "r"
    _add(results, range(12))  # not consolidated yet: `fallbench results` adds them first
    runner = CliRunner()
    result = runner.invoke(
        app,
        [
            "results",
            "--results",
            str(results),
            "--format",
            "csv",
            "--sql",
            "SELECT policy, count(*) AS runs, max(imu_peak_z) AS peak FROM runs GROUP BY policy ORDER BY policy",
        ],
    )
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == [
        "policy,runs,peak",
        "adaptive_qp,3,111.0",
        "oneshot,3,109.0",
        "stiff,3,108.0",
        "zero,3,110.0",
    ]
    filtered = runner.invoke(
        app,
        [
            "results",
            "--results",
            str(results),
            "--format",
            "csv",
            "--columns",
            "point,policy",
            "--policy",
            "zero,stiff",
            "--scenario",
            "family0",
        ],
    )
    assert filtered.exit_code == 0, filtered.output
    assert sorted(filtered.output.splitlines()[1:]) == ["p0,stiff", "p6,zero"]
    # no `robot` column in this store: its runs are of the schema's default robot
    robots = [
        runner.invoke(
            app,
            ["results", "--results", str(results), "--format", "csv", "--columns", "point", "--robot", robot],
        ).output.count("\n")
        for robot in (store.default_robot(), "g1")
    ]
    assert robots == [13, 1]
    bad = runner.invoke(app, ["results", "--results", str(results), "--sql", "SELECT nope FROM runs"])
    assert bad.exit_code == 2 and bad.stderr.count("\n") == 1 and "nope" in bad.stderr
    assert bad.stderr.startswith("error: --sql")
