"""Sweeps: expand scenarios into runs, simulate them with joblib, store each one, resume.

Workers (loky processes on this machine, or Dask workers on a cluster) only simulate and return
the metric row and time series; this process stores each run as it arrives. So a cluster needs no
shared file system, and the store is written by one process only.

One failing run never stops a sweep: it is stored with status `error` (exception) or `diverged`
(unstable simulation) and the sweep goes on.
"""

from __future__ import annotations

import hashlib
import time
import traceback
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from functools import cache
from importlib.metadata import version
from pathlib import Path
from typing import Any, Iterator

import mujoco
import numpy as np
import pandas as pd
from joblib import Parallel, delayed, parallel_config
from tqdm import tqdm

import fallbench
from fallbench import store
from fallbench.robots import get_robot
from fallbench.scenario import ScenarioPoint

@dataclass(frozen=True)
class RunSpec:
    point: ScenarioPoint
    policy: str
    pre_impact: str = "none"

    def resolved(self) -> dict[str, Any]:
        """Everything that determines the run's outcome, including software versions."""
        return {
            "scenario": self.point.scenario.model_dump(mode="json"),
            "policy": self.policy,
            "pre_impact": self.pre_impact,
            "versions": versions(self.point.scenario.robot),
        }

    @property
    def run_id(self) -> str:
        return store.run_id(self.resolved())


@cache
def code_fingerprint() -> str:
    """Hash of fallbench's own source: a code change gives new run ids, so a resumed sweep never
    mixes results of older code into the store."""
    digest = hashlib.sha256()
    for path in sorted(Path(fallbench.__file__).parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def versions(robot: str) -> dict[str, str]:
    return dict(_versions(robot))


@cache
def _versions(robot: str) -> tuple[tuple[str, str], ...]:
    """Installed versions never change within a process; reading package metadata costs ~1.5 ms."""
    return (("fallbench", fallbench.__version__), ("code", code_fingerprint()), ("mujoco", mujoco.__version__),
            ("pin", version("pin")), ("proxsuite", version("proxsuite")), ("robot", get_robot(robot).version))


def expand(points: list[ScenarioPoint], policies: list[str], pre_impact: list[str]) -> list[RunSpec]:
    """Every (point, strategy, policy); a scenario's own `pre_impact` list replaces `pre_impact`."""
    return [RunSpec(p, policy, pre) for p in points for pre in (p.scenario.pre_impact or pre_impact) for policy in policies]


def _identity(spec: RunSpec) -> dict[str, Any]:
    scenario = spec.point.scenario
    row: dict[str, Any] = {
        "run_id": spec.run_id, "schema_version": store.SCHEMA_VERSION, "robot": scenario.robot, "scenario": scenario.name,
        "point": spec.point.label, "source": spec.point.source, "policy": spec.policy,
        "pre_impact": spec.pre_impact, "seed": scenario.seed,
    }
    row.update({f"param:{k}": v for k, v in spec.point.swept.items()})
    row.update({f"version:{k}": v for k, v in versions(scenario.robot).items()})
    return row


@dataclass
class Outcome:
    spec: RunSpec
    row: dict[str, Any]
    series: pd.DataFrame | None


def simulate(spec: RunSpec) -> Outcome:
    """Run one case and compute its metrics. Never raises for a failing simulation."""
    from fallbench.episode import run_episode
    from fallbench.metrics import compute_metrics, timeseries

    started = time.perf_counter()
    row = _identity(spec)
    series = None
    try:
        recording = run_episode(spec.point.scenario, spec.policy, spec.pre_impact)
        row["status"], row["error"] = recording.status, recording.error
        with np.errstate(all="ignore"):  # a diverged recording holds NaNs; its metrics may too
            row.update(compute_metrics(recording))
            series = timeseries(recording)
    except Exception as exc:  # a failing run is stored, not raised: the sweep goes on
        row["status"] = "error"
        where = traceback.extract_tb(exc.__traceback__)[-1]
        row["error"] = f"{type(exc).__name__}: {exc} (at {Path(where.filename).name}:{where.lineno})"
    row["wall_time_s"] = time.perf_counter() - started
    return Outcome(spec, row, series)


def store_outcome(results: Path, outcome: Outcome) -> dict[str, Any]:
    spec = outcome.spec
    store.write_run(results, outcome.row["run_id"], spec.resolved() | {"point": spec.point.label}, outcome.row, outcome.series)
    return outcome.row


def execute(spec: RunSpec, results: Path) -> dict[str, Any]:
    """Run one case in this process, store it, return its metric row."""
    return store_outcome(results, simulate(spec))


BACKENDS = ("loky", "dask")


@contextmanager
def parallel_backend(backend: str, jobs: int, scheduler: str | None = None) -> Iterator[Parallel]:
    """joblib's Parallel on local processes (loky), or on a Dask cluster: the scheduler at
    `scheduler`, or a LocalCluster of `jobs` single-threaded worker processes."""
    if backend == "loky":
        yield Parallel(n_jobs=jobs, backend="loky" if jobs != 1 else "sequential", return_as="generator_unordered")
        return
    if backend != "dask":
        raise ValueError(f"unknown backend {backend!r}; known: {', '.join(BACKENDS)}")
    from dask.distributed import Client, LocalCluster

    with ExitStack() as stack:
        if scheduler:
            stack.enter_context(Client(scheduler))
        else:
            cluster = stack.enter_context(LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                                       dashboard_address=None))
            stack.enter_context(Client(cluster))
        stack.enter_context(parallel_config(backend="dask", wait_for_workers_timeout=60))
        yield Parallel(n_jobs=-1, return_as="generator_unordered")


def expected_cost(spec: RunSpec) -> float:
    """Relative wall time of a run (measured: a QP policy or reshaping costs ~5x a fixed-gain run),
    used to start the longest runs first so that no worker is left alone with one at the end."""
    return spec.point.scenario.duration * (1 + 4 * (spec.policy == "adaptive_qp") + 2 * (spec.pre_impact != "none"))


def run_sweep(specs: list[RunSpec], results: Path, jobs: int = 2, progress: bool = True,
              backend: str = "loky", scheduler: str | None = None) -> pd.DataFrame:
    """Run the specs not yet stored, add them to the consolidated table, return the specs' rows."""
    results.mkdir(parents=True, exist_ok=True)
    unique = {s.run_id: s for s in specs}
    todo = sorted((s for rid, s in unique.items() if not store.is_done(results, rid)), key=expected_cost, reverse=True)
    if todo:
        with parallel_backend(backend, jobs, scheduler) as parallel:
            outcomes: Iterator[Outcome] = parallel(delayed(simulate)(s) for s in todo)
            bar = tqdm(outcomes, total=len(todo), desc="falls", unit="run", disable=not progress,
                       initial=0, postfix={"skipped": len(unique) - len(todo)})
            for outcome in bar:
                row = store_outcome(results, outcome)
                bar.set_postfix_str(f"{row['pre_impact']}/{row['policy']} {row['point']}: {row['status']}")
    store.consolidate(results)
    table = store.load_metrics(results, scenario=sorted({s.point.scenario.name for s in unique.values()}))
    return table[table["run_id"].isin(set(unique))].reset_index(drop=True) if not table.empty else table
