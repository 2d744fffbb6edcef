"""Results store: one folder per run, written atomically, and a consolidated metrics table in parts.

results/runs/<run_id>/{spec.yaml, metrics.json, series.parquet} (layout LAYOUT_VERSION) is written
into a temporary folder, fsynced, then renamed: a run folder is either complete or absent, so an
interrupted sweep resumes by skipping the folders that exist. `metrics.json` holds the layout, the
time-series mode (`results.series`) and the metric row; runs of layout 1 (older stores) hold
{spec.yaml, metrics.parquet, timeseries.parquet} and are read as they are.

`consolidate` adds the runs that no part of results/metrics/ holds yet; the parts themselves (lock,
size-tiered merges, journal, common schema) are `results.parts`.

Queries go through DuckDB (`query`, `load_metrics`): it reads the parts with projection and
predicate push-down (row-group statistics; parts are sorted by robot, scenario, pre_impact, policy)
and answers SQL, for `fallbench results --sql`.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fallbench.results import parts
from fallbench.results.parts import FANOUT as FANOUT  # the parts' sizes and journal, read as store.X
from fallbench.results.parts import JOURNAL as JOURNAL
from fallbench.results.parts import MAX_PART_ROWS as MAX_PART_ROWS
from fallbench.results.series import DEFAULT_TIMESERIES, TIMESERIES_MODES, landing_windows
from fallbench.results.series import FILE as SERIES
from fallbench.results.series import encode as encode_series
from fallbench.scenario import canonical_json

if TYPE_CHECKING:  # pandas, pyarrow and DuckDB load only when the store is used (start-up time)
    import pandas as pd
    import pyarrow as pa

SCHEMA_VERSION = 1  # of the metric row (its `schema_version` column)
# of a run's folder: 1 = metrics.parquet + timeseries.parquet, 2 = metrics.json + series.parquet
LAYOUT_VERSION = 2
RUNS = "runs"
METRICS_JSON = "metrics.json"  # one run's layout, time-series mode and metric row, in its folder
METRICS = "metrics.parquet"  # one run's row, in its folder (layout 1)
LEGACY_SERIES = "timeseries.parquet"  # layout 1: every physics step, float32, qpos NaN off the replay rows
TABLE = "metrics"  # folder of the consolidated parts
LEGACY_TABLE = "metrics.parquet"  # results/metrics.parquet, rebuilt whole by older versions
FILTER_KEYS = ("scenario", "policy", "pre_impact", "robot")


def run_id(resolved_spec: dict[str, Any]) -> str:
    return hashlib.sha256(canonical_json(resolved_spec).encode()).hexdigest()[:16]


def run_dir(results: Path, rid: str) -> Path:
    return results / RUNS / rid


def is_done(results: Path, rid: str) -> bool:
    folder = run_dir(results, rid)
    return (folder / METRICS_JSON).exists() or (folder / METRICS).exists()


class SeriesMissing(FileNotFoundError):
    """The run is stored without a time series (`--timeseries none`)."""


def _json_scalar(value: Any) -> Any:
    """NumPy scalars as the Python values they stand for (float64 is a float already)."""
    import numpy as np

    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.integer) and value.dtype == np.int64:
        return int(value)
    raise TypeError(f"metric value {value!r} of type {type(value).__name__} has no exact JSON form")


def metrics_json(metrics: dict[str, Any], timeseries: str) -> bytes:
    """`metrics.json`: the row as JSON (floats in their shortest exact form, NaN as NaN), so that
    it reads back into the same Arrow types and bits as the row itself (`row_table`)."""
    envelope = {"layout": LAYOUT_VERSION, "timeseries": timeseries, "metrics": metrics}
    return json.dumps(envelope, default=_json_scalar, separators=(",", ":")).encode()


def row_table(metrics: dict[str, Any]) -> pa.Table:
    """One metric row as an Arrow table, as layout 1 stored it through pandas: bool, int64,
    double (NaN as null), large_string, null for None (~1 ms a row; through pandas ~16 ms)."""
    import pyarrow as pa

    types = ((bool, pa.bool_()), (int, pa.int64()), (float, pa.float64()), (str, pa.large_string()))

    def arrow_type(name: str, value: Any) -> pa.DataType:
        if value is None:
            return pa.null()
        for kind, arrow in types:  # bool before int: a bool is an int too
            if isinstance(value, kind):
                return arrow
        raise TypeError(f"metric {name}: value {value!r} of type {type(value).__name__} has no column type")

    return pa.table(
        {
            name: pa.array([value], type=arrow_type(name, value), from_pandas=True)
            for name, value in metrics.items()
        }
    )


def write_run(
    results: Path,
    rid: str,
    spec: dict[str, Any],
    metrics: dict[str, Any],
    series: pd.DataFrame | None,
    timeseries: str = DEFAULT_TIMESERIES,
) -> None:
    """Write one run's folder atomically; a run already stored is left as it is. `timeseries` is
    how much of the series to keep (`results.series`: landing, full or none)."""
    from ruamel.yaml import YAML

    if timeseries not in TIMESERIES_MODES:
        raise ValueError(f"unknown time-series mode {timeseries!r}; known: {', '.join(TIMESERIES_MODES)}")
    kept = timeseries if series is not None else "none"
    final = run_dir(results, rid)
    if final.exists():
        return
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.parent / f".tmp-{rid}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        text = io.StringIO()
        YAML(typ="safe", pure=True).dump(spec, text)
        parts.fsync_write(tmp / "spec.yaml", text.getvalue().encode())
        if kept != "none":
            data = encode_series(series, kept, landing_windows(metrics), LAYOUT_VERSION)
            parts.fsync_write(tmp / SERIES, data)
        parts.fsync_write(tmp / METRICS_JSON, metrics_json(metrics, kept))
        os.rename(tmp, final)
    except OSError:
        if final.exists():  # another worker stored the same run first
            shutil.rmtree(tmp, ignore_errors=True)
            return
        raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


# ---------------------------------------------------------------- consolidated parts


def _run_names(results: Path) -> list[str]:
    """Names of the complete run folders (one directory listing; nothing inside them is read)."""
    if not (results / RUNS).exists():
        return []
    with os.scandir(results / RUNS) as entries:
        return [e.name for e in entries if not e.name.startswith(".") and e.is_dir()]


def _run_row(results: Path, rid: str) -> pa.Table:
    """One stored run's metric row, of either layout."""
    import pyarrow.parquet as pq

    folder = run_dir(results, rid)
    if (folder / METRICS_JSON).exists():
        stored = json.loads((folder / METRICS_JSON).read_bytes())
        if stored["layout"] > LAYOUT_VERSION:
            raise ValueError(
                f"{folder}: stored by a newer fallbench (layout {stored['layout']}, this one reads up to {LAYOUT_VERSION})"
            )
        return row_table(stored["metrics"])
    return pq.read_table(folder / METRICS)


def load_run_row(results: Path, rid: str) -> pd.Series:
    """One stored run's metric row, from its folder."""
    return _run_row(results, rid).to_pandas().iloc[0]


def run_layout(results: Path, rid: str) -> tuple[int, str]:
    """(layout version, time-series mode) of a stored run; layout 1 kept every physics step."""
    folder = run_dir(results, rid)
    if (folder / METRICS_JSON).exists():
        about = json.loads((folder / METRICS_JSON).read_bytes())
        return int(about["layout"]), str(about["timeseries"])
    if (folder / METRICS).exists():
        return 1, "full" if (folder / LEGACY_SERIES).exists() else "none"
    raise FileNotFoundError(f"{folder}: no stored run")


def consolidate(results: Path, full: bool = False) -> int:
    """Add the stored runs that no part holds yet as one new part (or, with `full`, rebuild every
    part from the run folders); returns the number of rows added."""

    table = results / TABLE
    table.mkdir(parents=True, exist_ok=True)
    with parts.locked(table, exclusive=True):
        parts.recover(table)
        if full:
            for part in parts.live_parts(table):
                part.unlink()
            (table / parts.COMMON_METADATA).unlink(missing_ok=True)
        stored = parts.stored_ids(parts.live_parts(table))
        new = sorted(set(_run_names(results)) - stored)
        if new:
            parts.add_part(table, parts.concat([_run_row(results, rid) for rid in new]))
        (results / LEGACY_TABLE).unlink(missing_ok=True)  # the single-file table of older versions, now stale
    return len(new)


def add_rows(results: Path, rows: pa.Table) -> None:
    """Append metric rows as one part (for rows whose run folders exist or are not kept, e.g. the
    benchmark's synthetic store); `consolidate` is the way for stored runs."""
    table = results / TABLE
    table.mkdir(parents=True, exist_ok=True)
    with parts.locked(table, exclusive=True):
        parts.recover(table)
        parts.add_part(table, rows)


# ---------------------------------------------------------------- queries (DuckDB)


def _quote(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _sql_string(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


@contextmanager
def connect(results: Path) -> Iterator[Any]:
    """A DuckDB connection with the view `runs` over the store's parts (read under a shared lock)."""
    import duckdb

    table = results / TABLE
    if not table.is_dir():
        raise FileNotFoundError(f"{table}: no results store here (run `fallbench run sweep` first)")
    with parts.locked(table, exclusive=False):
        live = parts.live_parts(table)
        connection = duckdb.connect()
        try:
            if live:
                files = ", ".join(_sql_string(str(p)) for p in live)
                connection.execute(
                    f"CREATE VIEW runs AS SELECT * FROM read_parquet([{files}], union_by_name = true)"
                )
            yield connection
        finally:
            connection.close()


def _frame(relation: Any) -> pd.DataFrame:
    """DuckDB result as pandas, through Arrow: the same dtypes as pandas.read_parquet gives."""
    return relation.to_arrow_table().to_pandas()


def query(results: Path, sql: str) -> pd.DataFrame:
    """Run SQL on the view `runs` (one row per stored run); a bad statement raises ValueError."""
    import duckdb

    with connect(results) as connection:
        if not _has_runs(connection):
            raise FileNotFoundError(f"{results / TABLE}: the results store has no runs")
        try:
            return _frame(connection.sql(sql))
        except duckdb.Error as exc:
            raise ValueError(str(exc).splitlines()[0]) from None


def _has_runs(connection: Any) -> bool:
    return bool(
        connection.execute("SELECT count(*) FROM duckdb_views() WHERE view_name = 'runs'").fetchall()[0][0]
    )


def default_robot() -> str:
    """Runs stored before the `robot` column existed are of the scenario schema's default robot."""
    from fallbench.scenario import Scenario

    return str(Scenario.model_fields["robot"].default)


def load_metrics(results: Path, **filters: list[str] | None) -> pd.DataFrame:
    """The stored runs' rows, sorted by run id; `scenario`, `policy`, `pre_impact` and `robot`
    filters (lists of accepted values) are pushed down into the Parquet scan."""
    import pandas as pd

    unknown = set(filters) - set(FILTER_KEYS)
    if unknown:
        raise TypeError(f"unknown filter(s) {sorted(unknown)}; known: {', '.join(FILTER_KEYS)}")
    with connect(results) as connection:
        if not _has_runs(connection):
            return pd.DataFrame()
        columns = {row[0] for row in connection.execute("DESCRIBE runs").fetchall()}
        conditions = []
        for key, values in filters.items():
            if values is None:
                continue
            if key not in columns:  # only `robot` may be absent: older stores hold one robot
                if key == "robot" and default_robot() in values:
                    continue
                conditions.append("false")
                continue
            conditions.append(
                f"{_quote(key)} IN ({', '.join(_sql_string(v) for v in values)})" if values else "false"
            )
        where = f" WHERE {' AND '.join(conditions)}" if conditions else ""
        return _frame(connection.sql(f"SELECT * FROM runs{where} ORDER BY run_id"))


def has_timeseries(results: Path, rid: str) -> bool:
    folder = run_dir(results, rid)
    return (folder / SERIES).exists() or (folder / LEGACY_SERIES).exists()


def with_timeseries(results: Path, runs: pd.DataFrame) -> pd.DataFrame:
    """The runs (rows with `run_id`) whose time series is stored (not `--timeseries none`)."""
    return runs[runs.run_id.map(lambda rid: has_timeseries(results, rid)).astype(bool)]


def load_timeseries(results: Path, rid: str) -> pd.DataFrame:
    """A run's stored time series as float32 columns (`t` in s first), of either layout; raises
    SeriesMissing for a run stored with `--timeseries none`."""
    import pandas as pd
    import pyarrow.parquet as pq

    from fallbench.results.series import decode

    folder = run_dir(results, rid)
    if (folder / SERIES).exists():
        return decode(pq.read_table(folder / SERIES))
    if (folder / LEGACY_SERIES).exists():
        return pd.read_parquet(folder / LEGACY_SERIES)
    if is_done(results, rid):
        raise SeriesMissing(f"run {rid} was stored without its time series (--timeseries none)")
    raise FileNotFoundError(f"{folder}: no stored run")
