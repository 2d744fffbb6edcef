"""Results store: one folder per run, written atomically, and a consolidated metrics table.

results/runs/<run_id>/{spec.yaml, metrics.parquet, timeseries.parquet} is written into a temporary
folder, fsynced, then renamed: a run folder is either complete or absent, so an interrupted sweep
resumes by skipping the folders that exist. results/metrics.parquet is rebuilt from the folders.
"""

from __future__ import annotations

import hashlib
import io
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

import pandas as pd
from ruamel.yaml import YAML

from fallbench.scenario import canonical_json

SCHEMA_VERSION = 1
RUNS = "runs"
METRICS = "metrics.parquet"


def run_id(resolved_spec: dict[str, Any]) -> str:
    return hashlib.sha256(canonical_json(resolved_spec).encode()).hexdigest()[:16]


def run_dir(results: Path, rid: str) -> Path:
    return results / RUNS / rid


def is_done(results: Path, rid: str) -> bool:
    return (run_dir(results, rid) / METRICS).exists()


def _fsync_write(path: Path, data: bytes) -> None:
    with open(path, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


def _parquet_bytes(frame: pd.DataFrame) -> bytes:
    buffer = io.BytesIO()
    frame.to_parquet(buffer, index=False)
    return buffer.getvalue()


def write_run(results: Path, rid: str, spec: dict[str, Any], metrics: dict[str, Any], series: pd.DataFrame | None) -> None:
    """Write one run's folder atomically; a run already stored is left as it is."""
    final = run_dir(results, rid)
    if final.exists():
        return
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.parent / f".tmp-{rid}-{uuid.uuid4().hex[:8]}"
    tmp.mkdir()
    try:
        text = io.StringIO()
        YAML(typ="safe", pure=True).dump(spec, text)
        _fsync_write(tmp / "spec.yaml", text.getvalue().encode())
        if series is not None:
            _fsync_write(tmp / "timeseries.parquet", _parquet_bytes(series))
        _fsync_write(tmp / METRICS, _parquet_bytes(pd.DataFrame([metrics])))
        os.rename(tmp, final)
    except OSError:
        if final.exists():  # another worker stored the same run first
            shutil.rmtree(tmp, ignore_errors=True)
            return
        raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def read_run_metrics(results: Path) -> pd.DataFrame:
    """All stored runs' metric rows (leftover temporary folders are ignored)."""
    files = sorted((results / RUNS).glob("*/" + METRICS)) if (results / RUNS).exists() else []
    frames = [pd.read_parquet(f) for f in files if not f.parent.name.startswith(".tmp-")]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def consolidate(results: Path) -> pd.DataFrame:
    """Rebuild results/metrics.parquet from the run folders, atomically."""
    table = read_run_metrics(results)
    if not table.empty:
        table = table.sort_values("run_id").reset_index(drop=True)
    tmp = results / f".{METRICS}.{uuid.uuid4().hex[:8]}"
    _fsync_write(tmp, _parquet_bytes(table))
    os.replace(tmp, results / METRICS)
    return table


def load_metrics(results: Path) -> pd.DataFrame:
    path = results / METRICS
    if not path.exists():
        raise FileNotFoundError(f"{path}: no results store here (run `fallbench run sweep` first)")
    return pd.read_parquet(path)


def load_timeseries(results: Path, rid: str) -> pd.DataFrame:
    return pd.read_parquet(run_dir(results, rid) / "timeseries.parquet")
