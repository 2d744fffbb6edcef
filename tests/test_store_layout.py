"""Run folders of layout 2 (metrics.json + series.parquet): the row reads back bit-identical to
layout 1's metrics.parquet, `--timeseries landing|full|none` keep what they say, and a store of
layout 1 (and a store mixing both) stays readable."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from fallbench.checks import load
from fallbench.cli import app
from fallbench.report.render import ReplayMissing, load_replay
from fallbench.results import series, store
from fallbench.results.runner import Outcome, RunSpec, simulate, store_outcome

DROP = "name: drop\nduration: 0.6\ninitial: {height: 0.3}\n"


@pytest.fixture(scope="module")
def outcome(tmp_path_factory) -> Outcome:
    """A short drop that lands (an impact at ~0.25 s), simulated once."""
    folder = tmp_path_factory.mktemp("layout")
    (folder / "drop.yaml").write_text(DROP)
    result = simulate(RunSpec(load([folder / "drop.yaml"])[0], "adaptive_qp"))
    assert result.row["status"] == "ok" and np.isfinite(result.row["impact_time"])
    return result


def _bits(table: pa.Table) -> list[object]:
    """Each column's type, nulls and values, floats as their bit patterns (NaN payloads included)."""
    return [
        (
            str(column.type),
            column.is_null().to_pylist(),
            column.to_numpy(zero_copy_only=False).view(np.uint64).tolist()
            if pa.types.is_floating(column.type)
            else column.to_pylist(),
        )
        for column in table.columns
    ]


def _layout1_row(row: dict[str, object]) -> pa.Table:
    """The row as layout 1 stored it: pandas to Parquet, read back."""
    buffer = io.BytesIO()
    pd.DataFrame([row]).to_parquet(buffer, index=False)
    return pq.read_table(io.BytesIO(buffer.getvalue())).replace_schema_metadata(None)


def test_json_row_reads_back_bit_identical_to_layout_1(outcome: Outcome) -> None:
    row = outcome.row
    back = store.row_table(json.loads(store.metrics_json(row, "landing"))["metrics"])
    old = _layout1_row(row)
    assert back.replace_schema_metadata(None).schema == old.schema
    assert _bits(back) == _bits(old)
    assert {float, int, bool, str} <= {type(v) for v in row.values()}  # the row mixes types


def test_metric_values_json_cannot_hold_exactly_are_refused() -> None:
    with pytest.raises(TypeError, match="no exact JSON form"):
        store.metrics_json({"x": np.float32(0.1)}, "none")


def _store(tmp: Path, outcome: Outcome, mode: str) -> Path:
    results = tmp / mode
    store_outcome(results, outcome, mode)
    return results


def test_full_keeps_every_physics_step_exactly(outcome: Outcome, tmp_path: Path) -> None:
    results = _store(tmp_path, outcome, "full")
    rid = outcome.row["run_id"]
    kept = store.load_timeseries(results, rid)
    pd.testing.assert_frame_equal(kept, outcome.series)
    assert store.run_layout(results, rid) == (store.LAYOUT_VERSION, "full")


def test_landing_keeps_the_landing_at_physics_rate_within_resolution(
    outcome: Outcome, tmp_path: Path
) -> None:
    results = _store(tmp_path, outcome, "landing")
    rid, impact = outcome.row["run_id"], outcome.row["impact_time"]
    kept = store.load_timeseries(results, rid)
    assert list(kept.columns) == list(outcome.series.columns) and set(kept.dtypes) == {np.dtype("float32")}
    full = outcome.series.set_index(np.round(outcome.series.t.to_numpy(float) * 1e6).astype(int))
    t = np.round(kept.t.to_numpy(float) * 1e6).astype(int)
    original = full.loc[t]
    dt = outcome.spec.point.scenario.physics_dt
    window = (kept.t >= impact - series.LANDING_BEFORE) & (kept.t <= impact + series.LANDING_AFTER)
    assert np.allclose(np.diff(kept.t[window]), dt, atol=1e-6)  # every physics step in the landing
    assert window.sum() >= (series.LANDING_BEFORE + series.LANDING_AFTER) / dt
    windows = series.landing_windows(outcome.row)
    assert len(windows) == 1 + len(json.loads(outcome.row["impact_events"])) >= 2  # feet, and a later group
    for start, end in windows[1:]:  # each body group's first contact, at every physics step too
        inside = (kept.t >= start + 1e-6) & (kept.t <= end - 1e-6)
        assert np.allclose(np.diff(kept.t[inside]), dt, atol=1e-6) and inside.sum() >= 0.05 / dt
    outside = kept.t[~window & (kept.t < impact)]
    assert np.allclose(np.diff(outside), 0.01, atol=1e-6)  # the replay's 100 Hz before it
    for column in kept.columns:
        step = series.resolution(column)
        error = np.abs(kept[column].to_numpy(float) - original[column].to_numpy(float))
        scale = np.abs(original[column].to_numpy(float))
        bound = step / 2 + scale * 2.0**-23 + 1e-12  # half the resolution, and float32 rounding
        assert np.array_equal(np.isnan(error), original[column].isna().to_numpy()), column
        assert np.nanmax(error - bound) <= 0, column
    assert (results / "runs" / rid / "series.parquet").stat().st_size < 100 * 1024


def test_landing_keeps_every_step_about_later_contacts_too() -> None:
    """A head contact 1 s after the feet: its window is at the physics rate, between them 100 Hz."""
    dt, t = 0.0005, np.arange(0, 2.0, 0.0005)
    qpos = np.where(np.arange(len(t)) % 20 == 0, 1.0, np.nan)
    frame = pd.DataFrame({"t": t, "q:knee": np.sin(t), "qpos:0": qpos}).astype(np.float32)
    row = {"impact_time": 0.4, "impact_events": json.dumps([{"t": 0.4}, {"t": 1.4}])}
    windows = series.landing_windows(row)
    assert np.allclose(windows, [(0.35, 0.7), (0.39, 0.45), (1.39, 1.45)])
    kept = t[series.landing_rows(frame, windows)]
    assert np.allclose(np.diff(kept[(kept > 1.39) & (kept < 1.45)]), dt)
    assert np.allclose(np.diff(kept[(kept > 0.71) & (kept < 1.38)]), 0.01)
    assert len(kept) == 200 + (701 - 36) + (121 - 7)  # 100 Hz rows, then each window's steps not on them


def test_none_keeps_no_series_and_the_same_metrics(outcome: Outcome, tmp_path: Path) -> None:
    kept = {mode: _store(tmp_path, outcome, mode) for mode in series.TIMESERIES_MODES}
    rid = outcome.row["run_id"]
    rows = [_bits(store._run_row(results, rid)) for results in kept.values()]
    assert rows[0] == rows[1] == rows[2]
    assert not store.has_timeseries(kept["none"], rid)
    with pytest.raises(store.SeriesMissing, match="--timeseries none"):
        store.load_timeseries(kept["none"], rid)
    with pytest.raises(ReplayMissing, match="--timeseries landing or full"):
        load_replay(kept["none"], rid)
    assert load_replay(kept["landing"], rid).qpos.shape[1] == 39  # the replay stays in `landing`


def _write_layout1(results: Path, rid: str, row: dict[str, object], frame: pd.DataFrame) -> None:
    """A run folder as fallbench wrote them before layout 2."""
    folder = results / "runs" / rid
    folder.mkdir(parents=True)
    (folder / "spec.yaml").write_text((results.parent / "spec.yaml").read_text())
    pd.DataFrame([row]).to_parquet(folder / "metrics.parquet", index=False)
    frame.to_parquet(folder / "timeseries.parquet", index=False)


def test_a_layout_1_store_and_a_mixed_one_stay_readable(outcome: Outcome, tmp_path: Path) -> None:
    spec = outcome.spec.resolved() | {"point": outcome.spec.point.label}
    from ruamel.yaml import YAML

    text = io.StringIO()
    YAML(typ="safe", pure=True).dump(spec, text)
    (tmp_path / "spec.yaml").write_text(text.getvalue())
    results = tmp_path / "results"
    old_id = "0" * 16
    _write_layout1(results, old_id, outcome.row | {"run_id": old_id}, outcome.series)
    store.consolidate(results)
    assert store.run_layout(results, old_id) == (1, "full")
    pd.testing.assert_frame_equal(store.load_timeseries(results, old_id), outcome.series)
    assert store.load_run_row(results, old_id).run_id == old_id
    assert load_replay(results, old_id).time[1] == pytest.approx(0.01)
    # a new run appended to the old store: both read, each once
    store_outcome(results, outcome)
    store.consolidate(results)
    table = store.load_metrics(results)
    assert sorted(table.run_id) == sorted([old_id, outcome.row["run_id"]])
    numeric = [c for c in table.columns if pd.api.types.is_float_dtype(table[c])]
    pd.testing.assert_frame_equal(
        table.loc[table.run_id == old_id, numeric].reset_index(drop=True),
        table.loc[table.run_id != old_id, numeric].reset_index(drop=True),
    )
    rebuilt = store.consolidate(results, full=True)
    assert rebuilt == 2


def test_run_commands_refuse_an_unknown_timeseries_mode(tmp_path: Path) -> None:
    (tmp_path / "drop.yaml").write_text(DROP)
    for command in (["run", "sweep"], ["run", "one"]):
        result = CliRunner().invoke(
            app,
            [*command, str(tmp_path / "drop.yaml"), "--timeseries", "some", "--results", str(tmp_path / "r")],
        )
        assert result.exit_code == 2
        assert result.stderr.strip() == "error: --timeseries: unknown mode 'some'; known: landing, full, none"
        assert not (tmp_path / "r").exists()


def test_a_folder_of_a_newer_layout_is_refused_by_name(tmp_path: Path) -> None:
    folder = tmp_path / "runs" / "abc"
    folder.mkdir(parents=True)
    (folder / "metrics.json").write_text(json.dumps({"layout": 3, "timeseries": "none", "metrics": {}}))
    with pytest.raises(ValueError, match="stored by a newer fallbench .layout 3, this one reads up to 2"):
        store.load_run_row(tmp_path, "abc")
