"""Sweep throughput in this process and in 2 loky workers, the workers' peak memory, and the bytes
stored per run in each time-series mode."""

from __future__ import annotations

import os
import resource
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

from fallbench.bench.config import POLICIES
from fallbench.results.runner import Outcome, RunSpec, expected_cost, simulate, store_outcome
from fallbench.results.series import DEFAULT_TIMESERIES, TIMESERIES_MODES
from fallbench.scenario import ScenarioPoint


def _simulate_measured(spec: RunSpec) -> tuple[Outcome, int, float]:
    """simulate() in a worker, with the worker's pid and its own peak RSS so far (MB)."""
    outcome = simulate(spec)
    return outcome, os.getpid(), own_peak_rss_mb()


def own_peak_rss_mb() -> float:
    """This process's own peak RSS (MB): /proc's VmHWM. Linux keeps ru_maxrss across fork and exec,
    so a worker's ru_maxrss is at least its parent's peak when it was started."""
    try:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024
    except (OSError, StopIteration):  # not Linux
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def sweep_figures(specs: list[RunSpec]) -> dict[str, float]:
    """Runs/s with 1 job (this process) and 2 loky workers (warmed up first), storing every run."""
    figures: dict[str, float] = {"sweep_runs": len(specs)}
    specs = sorted(specs, key=expected_cost, reverse=True)  # as run_sweep orders them
    peaks: dict[int, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        for jobs in (1, 2):
            results = Path(folder) / f"jobs{jobs}"
            parallel = Parallel(
                n_jobs=jobs, backend="loky" if jobs > 1 else "sequential", return_as="generator_unordered"
            )
            if jobs > 1:
                started = time.perf_counter()
                warm = [replace(specs[0], point=_with_seed(specs[0].point, 10_000 + i)) for i in range(jobs)]
                list(parallel(delayed(_simulate_measured)(s) for s in warm))
                figures["worker_warmup_s"] = time.perf_counter() - started
            started, other_modes_s = time.perf_counter(), 0.0
            for outcome, pid, peak in parallel(delayed(_simulate_measured)(s) for s in specs):
                store_outcome(results, outcome)
                if jobs > 1:
                    peaks[pid] = max(peaks.get(pid, 0.0), peak)
                else:  # the same runs stored with the other time-series modes (not timed)
                    other_modes_s -= time.perf_counter()
                    for mode in TIMESERIES_MODES[1:]:
                        store_outcome(Path(folder) / mode, outcome, mode)
                    other_modes_s += time.perf_counter()
            elapsed = time.perf_counter() - started - other_modes_s
            figures[f"sweep_runs_per_s_{jobs}job"] = len(specs) / elapsed
        for mode in TIMESERIES_MODES:
            figures[f"bytes_per_run_{mode}"] = _bytes_per_run(
                Path(folder) / ("jobs1" if mode == "landing" else mode)
            )
        figures["bytes_per_run"] = figures[f"bytes_per_run_{DEFAULT_TIMESERIES}"]
    figures["sweep_speedup"] = figures["sweep_runs_per_s_2job"] / figures["sweep_runs_per_s_1job"]
    figures["worker_peak_rss_mb"] = max(peaks.values())
    figures["main_peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return figures


def _bytes_per_run(results: Path) -> float:
    """Mean bytes of a run's folder (spec, metrics, time series; file sizes, not disk blocks)."""
    return float(
        np.mean([sum(f.stat().st_size for f in run.iterdir()) for run in (results / "runs").iterdir()])
    )


def sweep_specs(point: ScenarioPoint, runs: int, pre_impact: str) -> list[RunSpec]:
    """`runs` distinct runs of the point (seeds 0..), cycling through the four policies."""
    return [
        RunSpec(_with_seed(point, i // len(POLICIES)), POLICIES[i % len(POLICIES)], pre_impact)
        for i in range(runs)
    ]


def _with_seed(point: ScenarioPoint, seed: int) -> ScenarioPoint:
    """The same point as a distinct run (its own run id) with the same work."""
    return replace(point, scenario=point.scenario.model_copy(update={"seed": seed}))
