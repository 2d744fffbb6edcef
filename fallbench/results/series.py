"""How a run's time series is stored (`--timeseries full|landing|none`), and read back.

`analysis.metrics.timeseries` gives the series at the physics rate (float32), with the full qpos
every 1/REPLAY_RATE s and NaN in between. The store keeps, in `series.parquet`:

- `landing` (the default): at every physics step, the rows of the landing, from LANDING_BEFORE s
  before the first impact to LANDING_AFTER s after it, and from EVENT_BEFORE s before to
  EVENT_AFTER s after each body group's first contact (the run's `impact_events`); elsewhere the
  rows the replay keeps (REPLAY_RATE, 100 Hz). Each value is rounded to its quantity's resolution (RESOLUTIONS) and
  stored as an integer count of that resolution (Parquet delta encoding + zstd): value = count x
  resolution, the resolutions by column-name prefix being in the file's key-value metadata
  `fallbench`. A run without an impact keeps the replay rows only.
- `full`: every physics step, float32 exactly as computed (byte-stream split + zstd).
- `none`: no time series (no replay, no paper figures of the run; the metrics are the same).

The metrics are computed from the recording before any of this, so the mode never changes them.
In every mode the qpos columns are null off the replay rows, and non-finite values read back as NaN.
"""

from __future__ import annotations

import io
import json
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa

TIMESERIES_MODES = ("landing", "full", "none")
DEFAULT_TIMESERIES = "landing"
LANDING_BEFORE = 0.05  # s before the first impact kept at every physics step
# s after it: covers 002 Fig. 5's landing column (0.25 s) and the metrics' landing window (0.15 s)
LANDING_AFTER = 0.30
EVENT_BEFORE, EVENT_AFTER = 0.01, 0.05  # s about each later first contact of a body group
# Resolution of each stored quantity, by column-name prefix (units of the column)
RESOLUTIONS: tuple[tuple[str, float], ...] = (
    ("t", 1e-6),  # s
    ("qpos:", 1e-4),  # m, quaternion units, rad (the replay)
    ("q:", 1e-5),  # rad (002 Fig. 5 differentiates the knee angle)
    ("base_", 1e-4),  # m
    ("com_", 1e-4),  # m
    ("imu_acc_", 1e-2),  # m/s^2
    ("tau:", 1e-2),  # Nm
    ("force:", 1e-1),  # N
    ("K:", 1e-1),  # Nm/rad
    ("B:", 1e-2),  # Nms/rad
)
LIMIT = 2**62  # counts beyond this (a diverged run) are stored as null
META_KEY = b"fallbench"
FILE = "series.parquet"


def resolution(column: str, resolutions: tuple[tuple[str, float], ...] = RESOLUTIONS) -> float | None:
    """The column's resolution, or None for a column stored as float32 as it is."""
    for prefix, step in resolutions:
        if column == prefix or (prefix.endswith((":", "_")) and column.startswith(prefix)):
            return step
    return None


def _replay_rows(series: pd.DataFrame) -> np.ndarray:
    qpos = [c for c in series.columns if c.startswith("qpos:")]
    if not qpos:
        return np.zeros(len(series), dtype=bool)
    return series[qpos[0]].notna().to_numpy()


def _finite(value: object) -> float | None:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return number if np.isfinite(number) else None


def landing_windows(metrics: dict[str, object]) -> list[tuple[float, float]]:
    """(start, end) in s of the rows `landing` keeps at every physics step: the landing about the
    first impact (`impact_time`), and a short window about each body group's first contact
    (`impact_events`: later impacts, e.g. hands, knees, torso, head)."""
    windows = []
    impact = _finite(metrics.get("impact_time"))
    if impact is not None:
        windows.append((impact - LANDING_BEFORE, impact + LANDING_AFTER))
    for event in json.loads(str(metrics.get("impact_events") or "[]")):
        t = _finite(event.get("t"))
        if t is not None:
            windows.append((t - EVENT_BEFORE, t + EVENT_AFTER))
    return windows


def landing_rows(series: pd.DataFrame, windows: list[tuple[float, float]]) -> np.ndarray:
    """Rows kept by `landing`: the replay rows, and every row within a window."""
    keep = _replay_rows(series).copy()
    t = series["t"].to_numpy(dtype=float)
    for start, end in windows:
        keep |= (t >= start - 1e-9) & (t <= end + 1e-9)
    return keep


def _counts(values: np.ndarray, step: float) -> pa.Array:
    import pyarrow as pa

    with np.errstate(invalid="ignore", over="ignore"):
        scaled = np.round(values.astype(np.float64) / step)
    bad = ~np.isfinite(scaled) | (np.abs(scaled) >= LIMIT)
    return pa.array(np.where(bad, 0, scaled).astype(np.int64), mask=bad)


def _quantised(frame: pd.DataFrame) -> pa.Table:
    """Integer counts of each column's resolution (a column of unknown resolution stays float32)."""
    import pyarrow as pa

    arrays = []
    for column in frame.columns:
        values = frame[column].to_numpy()
        step = resolution(column)
        arrays.append(pa.array(values.astype(np.float32)) if step is None else _counts(values, step))
    return pa.Table.from_arrays(arrays, names=list(frame.columns))


def _floats(frame: pd.DataFrame) -> pa.Table:
    import pyarrow as pa

    arrays = [pa.array(frame[c].to_numpy(np.float32), from_pandas=False) for c in frame.columns]
    table = pa.Table.from_arrays(arrays, names=list(frame.columns))
    qpos = [i for i, c in enumerate(frame.columns) if c.startswith("qpos:")]
    replay = _replay_rows(frame)
    for i in qpos:  # null, not NaN, off the replay rows (as in `landing`)
        table = table.set_column(
            i, table.field(i), pa.array(frame.iloc[:, i].to_numpy(np.float32), mask=~replay)
        )
    return table


def encode(series: pd.DataFrame, mode: str, windows: list[tuple[float, float]], layout: int) -> bytes:
    """The bytes of `series.parquet` for one run in `mode` (`landing`: the replay rows and
    `windows`, see landing_windows; `full`: every row)."""
    import pyarrow.parquet as pq

    header: dict[str, object] = {"layout": layout, "timeseries": mode}
    if mode == "landing":
        table = _quantised(series[landing_rows(series, windows)])
        header |= {
            "physics_rate_windows_s": [[round(s, 6), round(e, 6)] for s, e in windows],
            "resolutions": [list(r) for r in RESOLUTIONS],
        }
        options: dict[str, object] = {"column_encoding": "DELTA_BINARY_PACKED", "use_dictionary": False}
    elif mode == "full":
        table = _floats(series)
        options = {"use_byte_stream_split": True, "use_dictionary": False}
    else:
        raise ValueError(f"unknown time-series mode {mode!r}; known: {', '.join(TIMESERIES_MODES[:2])}")
    buffer = io.BytesIO()
    # no Arrow schema and no statistics in the footer: ~8 KiB a file at ~100 columns
    with pq.ParquetWriter(
        buffer,
        table.schema,
        compression="zstd",
        compression_level=9,
        write_statistics=False,
        store_schema=False,
        **options,
    ) as writer:
        writer.write_table(table)
        writer.add_key_value_metadata({META_KEY: json.dumps(header).encode()})
    return buffer.getvalue()


def decode(data: pa.Table) -> pd.DataFrame:
    """A stored series as float32 columns (NaN where null), whatever its mode."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.compute as pc

    resolutions = tuple((str(p), float(s)) for p, s in about(data).get("resolutions", []))
    columns = {}
    for name, column in zip(data.column_names, data.columns):
        step = resolution(name, resolutions)
        if step is not None and pa.types.is_integer(column.type):
            column = pc.multiply(pc.cast(column, "float64"), step)
        columns[name] = column.to_numpy(zero_copy_only=False).astype(np.float32)
    return pd.DataFrame(columns)


def about(data: pa.Table | pa.Schema) -> dict[str, object]:
    """The layout, mode and scales a stored series was written with."""
    meta = (data.schema if hasattr(data, "schema") else data).metadata or {}
    return json.loads(meta.get(META_KEY, b"{}"))
