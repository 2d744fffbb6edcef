"""Results store: incremental consolidation gives the full rebuild's table, an interrupted merge
never duplicates a row, the parts read in DuckDB and pandas, `fallbench results --sql` and filters."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import duckdb
import pandas as pd
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results import parts, store

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
    recover = parts.recover

    def crash_after_journal(table: Path) -> None:
        calls["n"] += 1
        if calls["n"] == 2:  # the merge's own recovery: the process dies right after the journal
            raise KeyboardInterrupt
        recover(table)

    monkeypatch.setattr(parts, "recover", crash_after_journal)
    with pytest.raises(KeyboardInterrupt):
        store.consolidate(results)
    monkeypatch.setattr(parts, "recover", recover)
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


# ---------------------------------------------------------------- two writers on one store

# A consolidation in its own process; with `hold`, it stops at a point of its work (before it adds
# its part, or in a merge just after the merged part has replaced its staged file, the parts it
# replaces not yet removed) until told to go on: <marks>/<name>.inside says it is there, the test
# creates <marks>/<name>.go. Prints the rows added.
CONSOLIDATE = """
import os, sys, time
from pathlib import Path
from fallbench.results import parts, store

results, marks, name, hold = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]


def pause():
    (marks / f"{name}.inside").touch()
    while not (marks / f"{name}.go").exists():
        time.sleep(0.005)


if hold == "add_part":
    add_part = parts.add_part

    def held(table, rows):
        pause()
        add_part(table, rows)

    parts.add_part = held
elif hold == "merged":
    replace = os.replace

    def held(src, dst):
        replace(src, dst)
        if str(src).endswith(".staged.tmp"):
            pause()

    store.os.replace = held
print(store.consolidate(results))
"""


def _consolidating(results: Path, marks: Path, name: str, hold: str = "") -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", CONSOLIDATE, str(results), str(marks), name, hold],
        stdout=subprocess.PIPE,
        text=True,
    )


def _wait_for(path: Path, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not path.exists():
        assert time.monotonic() < end, f"{path.name} never appeared"
        time.sleep(0.005)


def test_two_consolidations_at_once_add_each_run_once(tmp_path: Path) -> None:
    """A second consolidation (in this process) while another process's holds the lock: it waits,
    then finds every run in the first's part."""
    import threading

    results, marks = tmp_path / "r", tmp_path / "marks"
    marks.mkdir()
    _add(results, range(20))
    first = _consolidating(results, marks, "first", "add_part")
    _wait_for(marks / "first.inside")  # holding the lock, its part not written
    added: list[int] = []
    second = threading.Thread(target=lambda: added.append(store.consolidate(results)))
    second.start()
    second.join(timeout=0.5)
    assert second.is_alive()  # waiting for the lock (without it, it adds the 20 runs a second time)
    (marks / "first.go").touch()
    assert first.communicate(timeout=60)[0] == "20\n"
    second.join(timeout=60)
    assert added == [0]
    stored = store.load_metrics(results)
    assert len(stored) == 20 and stored.run_id.is_unique
    assert len(list((results / "metrics").glob("part-*.parquet"))) == 1


def test_a_reader_during_a_merge_sees_each_row_once(tmp_path: Path) -> None:
    """A merge stopped with the merged part in place and the parts it replaces not yet removed: a
    reader waits for it and then reads every run once."""
    import threading

    results, marks = tmp_path / "r", tmp_path / "marks"
    marks.mkdir()
    for i in range(store.FANOUT - 1):
        _add(results, range(i, i + 1))
        store.consolidate(results)
    _add(results, range(store.FANOUT - 1, store.FANOUT))  # the eighth part: a merge
    merging = _consolidating(results, marks, "merge", "merged")
    _wait_for(marks / "merge.inside")
    parts = list((results / "metrics").glob("part-*.parquet"))
    assert len(parts) == store.FANOUT + 1  # the merged part and the eight it replaces
    read: list[pd.DataFrame] = []
    reader = threading.Thread(target=lambda: read.append(store.load_metrics(results)))
    reader.start()
    reader.join(timeout=0.5)
    assert reader.is_alive()  # waiting for the merge (without the lock it reads every row twice)
    (marks / "merge.go").touch()
    assert merging.communicate(timeout=60)[0] == "1\n"
    reader.join(timeout=60)
    [rows] = read
    assert len(rows) == store.FANOUT and rows.run_id.is_unique


def test_two_writers_of_one_run_keep_the_first_stored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two workers finish the same run: the second to rename its folder finds the first's in place,
    keeps it and leaves no temporary folder behind."""
    results = tmp_path / "r"
    row = _row(1)
    rid = str(row["run_id"])
    write = parts.fsync_write
    raced = []

    def other_worker_first(path: Path, data: bytes) -> None:
        if path.name == store.METRICS_JSON and not raced:  # the other worker stores it meanwhile
            raced.append(path)
            store.write_run(results, rid, {"i": 1}, {**row, "imu_peak_z": -1.0}, None)
        write(path, data)

    monkeypatch.setattr(parts, "fsync_write", other_worker_first)
    store.write_run(results, rid, {"i": 1}, row, None)  # no error: the run is stored
    assert raced and store.is_done(results, rid)
    assert store.load_run_row(results, rid)["imu_peak_z"] == -1.0  # the first stored, kept whole
    assert [p.name for p in (results / store.RUNS).iterdir()] == [rid]  # no .tmp-* folder left
    assert store.consolidate(results) == 1
