"""The results store at N runs: synthetic rows shaped like a real run's, adding one run, a grouped
query, a filtered read."""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fallbench.bench.config import POLICIES, median_time
from fallbench.results.runner import Outcome

GROUPED_QUERY = (
    "SELECT scenario, pre_impact, policy, count(*) AS runs, median(imu_peak_z) AS imu_peak_z, "
    "min(knee_limit_margin) AS knee_limit_margin FROM runs GROUP BY ALL ORDER BY ALL"
)


def _synthetic_rows(template: dict[str, Any], first: int, count: int, seed: int) -> Any:
    """`count` metric rows shaped like `template` (a real run's row): 20 scenarios x 2 strategies
    x 4 policies, metrics scattered around the template's values."""
    import pyarrow as pa

    rng = np.random.default_rng(seed)
    index = np.arange(first, first + count)
    columns: dict[str, Any] = {}
    for key, value in template.items():
        if isinstance(value, bool) or isinstance(value, np.bool_):
            columns[key] = rng.random(count) < 0.5
        elif isinstance(value, float):
            columns[key] = value * (1 + 0.1 * rng.standard_normal(count))
        else:
            columns[key] = pa.array([value] * count)
    columns |= {
        "run_id": [f"{i:016x}" for i in index],
        "scenario": [f"scenario_{i % 20}" for i in index],
        "policy": [POLICIES[i % 4] for i in index],
        "pre_impact": [("none", "reshape")[i // 4 % 2] for i in index],
        "point": [f"scenario_{i % 20}#s{i}" for i in index],
        "seed": index,
    }
    return pa.table(columns)


def store_figures(
    outcome: Outcome, runs: int, repeats: int, progress: Callable[[str], None]
) -> dict[str, float]:
    """The results store at `runs` synthetic runs (a run folder each, as in a real store): adding
    one real run (its folder, then `consolidate`) at least 8 times, so the first tier merges once;
    a grouped SQL query; a read filtered by scenario and policy (pushed down)."""
    from fallbench.results import store

    figures: dict[str, float] = {"store_runs": runs}
    with tempfile.TemporaryDirectory() as folder:
        results = Path(folder)
        progress(f"store: building {runs:,} synthetic runs")
        started = time.perf_counter()
        (results / store.RUNS).mkdir()
        for first in range(0, runs, store.MAX_PART_ROWS):
            rows = _synthetic_rows(outcome.row, first, min(store.MAX_PART_ROWS, runs - first), first)
            for rid in rows.column("run_id").to_pylist():
                (results / store.RUNS / rid).mkdir()
            store.add_rows(results, rows)
        figures["store_build_s"] = time.perf_counter() - started
        progress("store: adding runs, querying")
        adds = []
        for i in range(max(8, repeats)):
            row = outcome.row | {"run_id": f"added{i:011d}"}
            started = time.perf_counter()
            store.write_run(results, row["run_id"], {"bench": i}, row, outcome.series)
            store.consolidate(results)
            adds.append(time.perf_counter() - started)
        figures["store_add_one_s_median"], figures["store_add_one_s_max"] = statistics.median(adds), max(adds)
        figures["store_query_s_median"] = median_time(lambda: store.query(results, GROUPED_QUERY), repeats)
        figures["store_filtered_read_s_median"] = median_time(
            lambda: store.load_metrics(results, scenario=["scenario_3"], policy=["stiff"]), repeats
        )
        figures["store_parts"] = len(list((results / store.TABLE).glob("part-*.parquet")))
        figures["store_table_mb"] = sum(p.stat().st_size for p in (results / store.TABLE).iterdir()) / 1e6
    return figures
