"""Consolidated parts of the results store: results/metrics/part-*.parquet hold every run's metric
row, each run in exactly one part.

A consolidation (`results.store.consolidate`) appends one part with the runs not yet in any part
(it reads only their folders: O(new runs)), then merges parts size-tiered, FANOUT parts of a tier
into one of the next tier. A part of MAX_PART_ROWS rows or more is final: a merge rewrites fewer
than FANOUT x MAX_PART_ROWS rows, a row is rewritten at most 4 times, and a store of N runs has at
most N / MAX_PART_ROWS + 4 x (FANOUT - 1) parts. A merge is journalled (_merge.json) before it
renames anything, so an interrupted one is finished by the next consolidation or read and a row is
never seen twice. results/metrics/_common_metadata holds the schema of all parts together. One
consolidation at a time holds the folder's lock; readers take it shared.
"""

from __future__ import annotations

import fcntl
import json
import os
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pyarrow loads only when the store is used (start-up time)
    import pyarrow as pa

COMMON_METADATA = "_common_metadata"
JOURNAL = "_merge.json"
LOCK = "_lock"
FANOUT = 8
MAX_PART_ROWS = FANOUT**4  # 4,096 rows: a part this big is final, so a merge rewrites < 8 x 4,096 rows
ROW_GROUP_ROWS = 4096
SORT_KEYS = ("robot", "scenario", "pre_impact", "policy", "run_id")


def fsync_write(path: Path, data: bytes) -> None:
    """Write, flush, fsync: the file whole on disk (a run folder's files, the merge journal)."""
    with open(path, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


@contextmanager
def locked(table: Path, exclusive: bool) -> Iterator[None]:
    """One consolidation at a time; readers wait for it (fcntl locks die with their process)."""
    with open(table / LOCK, "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def live_parts(table: Path) -> list[Path]:
    """Live parts, oldest first (names start with a nanosecond time stamp)."""
    return sorted(table.glob("part-*.parquet"))


def _write_table(path: Path, data: pa.Table) -> None:
    """Write, fsync, rename: a reader sees the whole part or none of it."""
    import pyarrow.parquet as pq

    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex[:8]}.tmp"
    with open(tmp, "wb") as handle:
        pq.write_table(data, handle, row_group_size=ROW_GROUP_ROWS)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)


def _new_part_path(table: Path) -> Path:
    return table / f"part-{time.time_ns():020d}-{uuid.uuid4().hex[:8]}.parquet"


def recover(table: Path) -> None:
    """Finish a merge interrupted after its journal was written; drop stray temporary files."""
    journal = table / JOURNAL
    if journal.exists():
        plan = json.loads(journal.read_text())
        staged, merged = table / plan["staged"], table / plan["merged"]
        if staged.exists():
            os.replace(staged, merged)
        for name in plan["replaced"]:
            (table / name).unlink(missing_ok=True)
        journal.unlink()
    for stray in table.glob(".*.tmp"):
        stray.unlink()


def _sorted(data: pa.Table) -> pa.Table:
    keys = [(k, "ascending") for k in SORT_KEYS if k in data.column_names]
    return data.sort_by(keys).replace_schema_metadata(None)


def concat(tables: list[pa.Table]) -> pa.Table:
    import pyarrow as pa

    return pa.concat_tables([t.replace_schema_metadata(None) for t in tables], promote_options="permissive")


def _store_schema(table: Path) -> pa.Schema | None:
    import pyarrow.parquet as pq

    path = table / COMMON_METADATA
    return pq.read_schema(path) if path.exists() else None


def _conform(data: pa.Table, schema: pa.Schema | None) -> pa.Table:
    """Columns that are all null in this batch take the store's type for them, so that every
    part of the store agrees on each column's type (pandas and polars read the folder directly)."""
    import pyarrow as pa

    if schema is None:
        return data
    for i, field in enumerate(data.schema):
        if pa.types.is_null(field.type) and field.name in schema.names:
            data = data.set_column(i, field.name, pa.nulls(len(data), schema.field(field.name).type))
    return data


def _write_common_metadata(table: Path, parts: list[Path]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = pa.unify_schemas(
        [pq.read_schema(p).remove_metadata() for p in parts], promote_options="permissive"
    )
    tmp = table / f".{COMMON_METADATA}.{uuid.uuid4().hex[:8]}.tmp"
    pq.write_metadata(schema, tmp)
    os.replace(tmp, table / COMMON_METADATA)


def stored_ids(parts: list[Path]) -> set[str]:
    import pyarrow.parquet as pq

    return {rid for part in parts for rid in pq.read_table(part, columns=["run_id"]).column(0).to_pylist()}


def _tier(rows: int) -> int:
    tier = 0
    while rows >= FANOUT ** (tier + 1):
        tier += 1
    return tier


def _merge(table: Path, group: list[Path]) -> None:
    """Replace `group` by one part, journalled so that an interruption never leaves a row twice."""
    import pyarrow.parquet as pq

    merged = _new_part_path(table)
    staged = table / f".{merged.name}.staged.tmp"
    data = _sorted(concat([pq.read_table(p) for p in group]))
    with open(staged, "wb") as handle:
        pq.write_table(data, handle, row_group_size=ROW_GROUP_ROWS)
        handle.flush()
        os.fsync(handle.fileno())
    plan = {"staged": staged.name, "merged": merged.name, "replaced": [p.name for p in group]}
    journal_tmp = table / f".{JOURNAL}.tmp"
    fsync_write(journal_tmp, json.dumps(plan).encode())
    os.replace(journal_tmp, table / JOURNAL)
    recover(table)  # the same steps a later process takes after a crash


def _compact(table: Path) -> None:
    """Size-tiered merging: FANOUT parts of one tier become one part of a higher tier."""
    import pyarrow.parquet as pq

    while True:
        tiers: dict[int, list[Path]] = {}
        for part in live_parts(table):
            rows = pq.read_metadata(part).num_rows
            if rows < MAX_PART_ROWS:
                tiers.setdefault(_tier(rows), []).append(part)
        full = next((group for _, group in sorted(tiers.items()) if len(group) >= FANOUT), None)
        if full is None:
            return
        _merge(table, full)


def add_part(table: Path, rows: pa.Table) -> None:
    _write_table(_new_part_path(table), _sorted(_conform(rows, _store_schema(table))))
    _compact(table)
    _write_common_metadata(table, live_parts(table))
