"""Sweeps: expand scenarios into runs, simulate them in parallel, store each one, resume.

Backends (`choose_backend`): one job or one run runs in this process; on this machine, `fork`
workers are forked from this process once it has imported the simulation code and compiled the
sweep's worlds and Pinocchio models, so they start in milliseconds instead of re-importing
everything (~1 s each), and each stores its own runs (a run folder is written atomically, under
its own name). `loky` (fresh processes) and `dask` workers only simulate and return the metric row
and time series; this process stores each run as it arrives, so a cluster needs no shared disk.

One failing run never stops a sweep: it is stored with status `error` (exception) or `diverged`
(unstable simulation) and the sweep goes on.
"""

from __future__ import annotations

import hashlib
import importlib
import multiprocessing
import signal
import time
import traceback
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from functools import cache, partial
from importlib.metadata import version
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

import fallbench
from fallbench.results import store
from fallbench.robots import get_robot
from fallbench.scenario import ScenarioPoint

if TYPE_CHECKING:  # pandas and joblib load only when a run or a parallel sweep needs them (start-up time)
    import pandas as pd
    from joblib import Parallel


@dataclass(frozen=True)
class RunSpec:
    point: ScenarioPoint
    policy: str
    pre_impact: str = "none"

    def resolved(self) -> dict[str, Any]:
        """Everything that determines the run's outcome, including software versions and the
        content of the files the strategy reads (a policy model)."""
        resolved = {
            "scenario": self.point.scenario.model_dump(mode="json"),
            "policy": self.policy,
            "pre_impact": self.pre_impact,
            "versions": versions(self.point.scenario.robot),
        }
        inputs = strategy_inputs(self.pre_impact, self.point.scenario)
        return resolved | {"inputs": inputs} if inputs else resolved

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
    return (
        ("fallbench", fallbench.__version__),
        ("code", code_fingerprint()),
        ("mujoco", mujoco.__version__),
        ("pin", version("pin")),
        ("proxsuite", version("proxsuite")),
        ("daqp", version("daqp")),
        ("numba", version("numba")),
        ("numpy", version("numpy")),
        ("scipy", version("scipy")),
        ("robot", get_robot(robot).version),
        ("robot_card", get_robot(robot).fingerprint),  # the card and its model files
    )


def strategy_inputs(pre_impact: str, scenario: Any) -> dict[str, str]:
    """Files the strategy reads in this scenario, path -> content digest (none for most)."""
    from fallbench.registry import strategies

    strategy = strategies().get(pre_impact)
    return strategy.inputs(scenario) if strategy is not None else {}


def expand(points: list[ScenarioPoint], policies: list[str], pre_impact: list[str]) -> list[RunSpec]:
    """Every (point, strategy, policy); a scenario's own `pre_impact` list replaces `pre_impact`.
    A whole-fall strategy runs once per point, with the policy `-`."""
    from fallbench.registry import run_policy

    return [
        RunSpec(p, label, pre)
        for p in points
        for pre in (p.scenario.pre_impact or pre_impact)
        for label in dict.fromkeys(run_policy(pre, policy) for policy in policies)
    ]


def identity(spec: RunSpec) -> dict[str, Any]:
    scenario = spec.point.scenario
    row: dict[str, Any] = {
        "run_id": spec.run_id,
        "schema_version": store.SCHEMA_VERSION,
        "robot": scenario.robot,
        "scenario": scenario.name,
        "point": spec.point.label,
        "group": spec.point.group,
        "source": spec.point.source,
        "policy": spec.policy,
        "pre_impact": spec.pre_impact,
        "seed": scenario.seed,
        "physics_dt": scenario.physics_dt,
    }
    row.update({f"param:{k}": v for k, v in spec.point.swept.items()})
    row.update({f"version:{k}": v for k, v in versions(scenario.robot).items()})
    return row


@dataclass
class Outcome:
    spec: RunSpec
    row: dict[str, Any]
    series: pd.DataFrame | None


def simulate(spec: RunSpec, keep_series: bool = True) -> Outcome:
    """Run one case and compute its metrics (and, with `keep_series`, its time series); never
    raises for a failing simulation. The metrics come from the recording, never from the series."""
    from fallbench.analysis.metrics import compute_metrics, group_forces, timeseries
    from fallbench.assembly import simulate_named

    started = time.perf_counter()
    row = identity(spec)
    series = None
    try:
        recording = simulate_named(spec.point.scenario, spec.policy, spec.pre_impact)
        row["status"], row["error"] = recording.status, recording.error
        with np.errstate(all="ignore"):  # a diverged recording holds NaNs; its metrics may too
            forces = group_forces(recording)  # read by both (1.6 ms a 3000-step run)
            row.update(compute_metrics(recording, forces))
            series = timeseries(recording, forces) if keep_series else None
    except Exception as exc:  # a failing run is stored, not raised: the sweep goes on
        row["status"] = "error"
        where = traceback.extract_tb(exc.__traceback__)[-1]
        row["error"] = f"{type(exc).__name__}: {exc} (at {Path(where.filename).name}:{where.lineno})"
    row["wall_time_s"] = time.perf_counter() - started
    return Outcome(spec, row, series)


def store_outcome(
    results: Path, outcome: Outcome, timeseries: str = store.DEFAULT_TIMESERIES
) -> dict[str, Any]:
    spec = outcome.spec
    store.write_run(
        results,
        outcome.row["run_id"],
        spec.resolved() | {"point": spec.point.label},
        outcome.row,
        outcome.series,
        timeseries,
    )
    return outcome.row


def execute(spec: RunSpec, results: Path, timeseries: str = store.DEFAULT_TIMESERIES) -> dict[str, Any]:
    """Run one case in this process, store it (its time series as `timeseries` says), return its
    metric row."""
    return store_outcome(results, simulate(spec, keep_series=timeseries != "none"), timeseries)


BACKENDS = ("auto", "fork", "loky", "dask")


def choose_backend(backend: str, jobs: int, runs: int) -> str:
    """`auto`: this process (`sequential`) for one job or one run; else `fork` where the OS forks
    (Linux, macOS), else `loky`. Any other name is taken as given."""
    if backend != "auto":
        return backend
    if jobs == 1 or runs <= 1:
        return "sequential"
    return "fork" if "fork" in multiprocessing.get_all_start_methods() else "loky"


def prepare(specs: list[RunSpec]) -> None:
    """Import the simulation code and compile the specs' worlds and Pinocchio models in this
    process (at most the world cache's size), so that forked workers inherit them."""
    from fallbench.dynamics.model import pinocchio_for
    from fallbench.sim.world import SCENES_KEPT, scene_key, scene_world

    for module in ("fallbench.sim.episode", "fallbench.analysis.metrics"):  # policies, strategies, pandas
        importlib.import_module(module)
    scenes: set[str] = set()
    for spec in specs:
        key = scene_key(spec.point.scenario)
        if key not in scenes:
            if len(scenes) == SCENES_KEPT:  # compiling more would evict these
                break
            scenes.add(key)
            pinocchio_for(scene_world(spec.point.scenario))


@contextmanager
def parallel_backend(backend: str, jobs: int, scheduler: str | None = None) -> Iterator[Parallel]:
    """joblib's Parallel on fresh local processes (loky), or on a Dask cluster: the scheduler at
    `scheduler`, or a LocalCluster of `jobs` single-threaded worker processes."""
    from joblib import Parallel, parallel_config

    if backend == "loky":
        yield Parallel(n_jobs=jobs, backend="loky", return_as="generator_unordered")
        return
    if backend != "dask":
        raise ValueError(f"unknown backend {backend!r}; known: {', '.join(BACKENDS)}")
    from dask.distributed import Client, LocalCluster

    with ExitStack() as stack:
        if scheduler:
            stack.enter_context(Client(scheduler))
        else:
            cluster = stack.enter_context(
                LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None)
            )
            stack.enter_context(Client(cluster))
        stack.enter_context(parallel_config(backend="dask", wait_for_workers_timeout=60))
        yield Parallel(n_jobs=-1, return_as="generator_unordered")


def stored_rows(
    todo: list[RunSpec],
    results: Path,
    backend: str,
    jobs: int,
    scheduler: str | None = None,
    timeseries: str = store.DEFAULT_TIMESERIES,
) -> Iterator[dict[str, Any]]:
    """Run and store every spec of `todo` (in this order where the backend keeps it); yield each
    run's metric row as it is stored."""
    if backend == "sequential":
        for spec in todo:
            yield execute(spec, results, timeseries)
    elif backend == "fork":
        prepare(todo)
        # Ctrl-C reaches this process only; leaving the `with` terminates the workers
        with multiprocessing.get_context("fork").Pool(
            jobs, initializer=signal.signal, initargs=(signal.SIGINT, signal.SIG_IGN)
        ) as pool:
            yield from pool.imap_unordered(partial(execute, results=results, timeseries=timeseries), todo)
    else:
        from joblib import delayed

        with parallel_backend(backend, jobs, scheduler) as parallel:
            keep = timeseries != "none"
            for outcome in parallel(delayed(simulate)(s, keep) for s in todo):
                yield store_outcome(results, outcome, timeseries)


def expected_cost(spec: RunSpec) -> float:
    """Relative wall time of a run (measured: a QP policy or reshaping costs ~5x a fixed-gain run;
    physics steps per simulated second), used to start the longest runs first so that no worker is
    left alone with one at the end. Runs end at rest, so their cap says little of their length."""
    return (1.0 / spec.point.scenario.physics_dt) * (
        1 + 4 * (spec.policy == "adaptive_qp") + 2 * (spec.pre_impact != "none")
    )


def run_sweep(
    specs: list[RunSpec],
    results: Path,
    jobs: int = 2,
    progress: bool = True,
    backend: str = "auto",
    scheduler: str | None = None,
    timeseries: str = store.DEFAULT_TIMESERIES,
) -> pd.DataFrame:
    """Run the specs not yet stored (keeping their time series as `timeseries` says: landing, full
    or none), add them to the consolidated table, return the specs' rows."""
    from tqdm import tqdm

    results.mkdir(parents=True, exist_ok=True)
    unique = {s.run_id: s for s in specs}
    todo = sorted(
        (s for rid, s in unique.items() if not store.is_done(results, rid)), key=expected_cost, reverse=True
    )
    if todo:
        rows = stored_rows(
            todo, results, choose_backend(backend, jobs, len(todo)), jobs, scheduler, timeseries
        )
        bar = tqdm(
            rows,
            total=len(todo),
            desc="falls",
            unit="run",
            disable=not progress,
            initial=0,
            postfix={"skipped": len(unique) - len(todo)},
        )
        for row in bar:
            bar.set_postfix_str(f"{row['pre_impact']}/{row['policy']} {row['point']}: {row['status']}")
    store.consolidate(results)
    table = store.load_metrics(results, scenario=sorted({s.point.scenario.name for s in unique.values()}))
    return table[table["run_id"].isin(set(unique))].reset_index(drop=True) if not table.empty else table
