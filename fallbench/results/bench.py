"""`fallbench bench`: fallbench's cost against the physics limit, 2-core sweep scaling, memory.

Everything is measured in one process on the same compiled model, medians of repeats:
- pure physics: mj_step on the scenario's model with the default servo and no controller;
- per policy: episode wall time / pure-physics wall time for the same number of steps, and
  / the time the episode itself spent in mj_step (a collapsing robot has more contacts, so its
  physics costs more than the standing robot's; the second ratio is the controller's overhead);
- controller cost per control step where a controller ran, and the QP's model/build/solve parts;
  `adaptive_qp` once with each QP solver (ProxSuite, the default, and DAQP);
- the reshaping QP's step (model, tasks, build, solve) on a 370 N forward push with `reshape`, with
  each QP solver;
- sweep throughput with 1 and 2 jobs on the same run list (warm workers), peak RSS per worker,
  and bytes stored per run;
- whole commands, start-up included, each in a fresh interpreter: a sweep of shipped drops and
  pushes (four policies, no reshaping) with 1 and 2 jobs, `fallbench run one` on the point, and
  the import time of what `run one` loads;
- the results store at N runs (synthetic rows with a real run's schema): adding one run, a
  grouped SQL query, a read filtered by scenario and policy;
- the Gymnasium environment (`fallbench/Fall-v0`, with the `learned` extra): its steps per second
  over whole episodes of random actions, against the time the same steps spent in mj_step.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from joblib import Parallel, delayed

from fallbench.analysis.metrics import compute_metrics
from fallbench.dynamics.dense_qp import QP_SOLVERS
from fallbench.registry import load, simulate_named
from fallbench.results.runner import Outcome, RunSpec, expected_cost, simulate, store_outcome
from fallbench.results.series import DEFAULT_TIMESERIES, TIMESERIES_MODES
from fallbench.scenario import DEFAULT_PHYSICS_DT, Scenario, ScenarioPoint
from fallbench.sim.servo import ServoCommand, write_servo
from fallbench.sim.world import build_world, initial_state

POLICIES = ("stiff", "oneshot", "zero", "adaptive_qp")
FIXED = ("stiff", "oneshot", "zero")
# the reshaping QP's bench fall: a front push; reshaping runs from fall detection to the first impact (~1.4 s)
RESHAPE_PUSH = Scenario(
    name="bench_reshape_push",
    duration=1.45,
    pre_impact=["reshape"],
    push={"force": 370.0, "duration": 0.1, "start": 0.1, "direction": 0.0},
)


def _suffix(solver: str) -> str:
    """Figure-key suffix of a QP solver: none for the default (ProxSuite), `_daqp` for DAQP."""
    return "" if solver == QP_SOLVERS[0] else f"_{solver}"


def with_qp_solver(scenario: Scenario, solver: str) -> Scenario:
    """The scenario with both QPs (adaptive_qp, reshape) on `solver`."""
    params = {
        name: {**scenario.policy_params.get(name, {}), "solver": solver}
        for name in ("adaptive_qp", "reshape")
    }
    return scenario.model_copy(update={"policy_params": {**scenario.policy_params, **params}})


# target name -> (figure key, comparison, limit): the targets docs/bench.md states
TARGETS: dict[str, tuple[str, str, float]] = {
    **{f"{p} episode / pure physics": (f"episode_ratio_{p}", "<=", 1.15) for p in FIXED},
    **{
        f"adaptive_qp ({solver}) episode / pure physics": (
            f"episode_ratio_adaptive_qp{_suffix(solver)}",
            "<=",
            2.0,
        )
        for solver in QP_SOLVERS
    },
    **{
        f"adaptive_qp ({solver}) QP step median (ms)": (f"qp_step_ms_median{_suffix(solver)}", "<=", 0.3)
        for solver in QP_SOLVERS
    },
    **{
        f"adaptive_qp ({solver}) QP step p99 (ms)": (f"qp_step_ms_p99{_suffix(solver)}", "<=", 1.0)
        for solver in QP_SOLVERS
    },
    **{
        f"reshape ({solver}) QP step median (ms)": (f"reshape_step_ms_median{_suffix(solver)}", "<=", 1.0)
        for solver in QP_SOLVERS
    },
    "2-job / 1-job sweep throughput": ("sweep_speedup", ">=", 1.8),
    "worker peak RSS (MB)": ("worker_peak_rss_mb", "<=", 500.0),
    "20-run sweep, 2 jobs vs 1, whole command": ("e2e_speedup_20", ">=", 1.6),
    "100-run sweep, 2 jobs vs 1, whole command": ("e2e_speedup_100", ">=", 1.9),
    "`run one`, whole command (s)": ("run_one_s", "<=", 1.0),
    "store: add one run, worst of the adds (s)": ("store_add_one_s_max", "<=", 2.0),
    "report of the given store, cold (s)": ("report_cold_s", "<=", 30.0),
    "report of the given store, warm (s)": ("report_warm_s", "<=", 10.0),
    "store: grouped query (s)": ("store_query_s_median", "<=", 1.0),
    "Gymnasium env: time added to its physics (fraction)": ("env_overhead", "<=", 0.30),
}
# a QP target's figure -> the same figure of the solver's part alone (a floor that no work outside the solver lowers)
SOLVER_SHARE = {
    f"{step}{_suffix(solver)}": f"{solve}{_suffix(solver)}"
    for solver in QP_SOLVERS
    for step, solve in (
        ("qp_step_ms_median", "qp_solve_ms_median"),
        ("qp_step_ms_p99", "qp_solve_ms_p99"),
        ("reshape_step_ms_median", "reshape_solve_ms_median"),
    )
}
GROUPED_QUERY = (
    "SELECT scenario, pre_impact, policy, count(*) AS runs, median(imu_peak_z) AS imu_peak_z, "
    "min(knee_limit_margin) AS knee_limit_margin FROM runs GROUP BY ALL ORDER BY ALL"
)


def _median_time(function: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def pure_physics_s(point: ScenarioPoint, steps: int) -> float:
    """Wall time of `steps` mj_step calls on the scenario's compiled model, default servo held."""
    world = build_world(point.scenario)
    data = initial_state(world, point.scenario)
    write_servo(
        world.model, data, ServoCommand(world.default_kp, world.default_kd, data.ctrl.copy(), 0 * data.ctrl)
    )
    started = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(world.model, data)
    return time.perf_counter() - started


def policy_figures(
    scenario: Scenario, policy: str, pre_impact: str, repeats: int, physics_s: float, suffix: str = ""
) -> dict[str, float]:
    """Episode and controller figures of one policy; keys end in `suffix` (a QP solver variant). One
    episode first, not counted: a process's first QP step loads the compiled kernels (~0.1 s, a
    start-up cost, measured by the whole-command figures), which the median of two would halve in."""
    simulate_named(scenario, policy, pre_impact)
    walls, own, recordings = [], [], []
    for _ in range(repeats):
        started = time.perf_counter()
        recording = simulate_named(scenario, policy, pre_impact)
        walls.append(time.perf_counter() - started)
        own.append(recording.physics_s)
        recordings.append(recording)
    wall = statistics.median(walls)
    active = np.concatenate([r.controller_ms[r.controller_ms > 0] for r in recordings])
    name = policy + suffix
    figures = {
        f"episode_s_{name}": wall,
        f"episode_ratio_{name}": wall / physics_s,
        f"episode_ratio_own_physics_{name}": wall / statistics.median(own),
        f"controller_ms_median_{name}": float(np.median(active)) if len(active) else 0.0,
        f"controller_ms_p99_{name}": float(np.percentile(active, 99)) if len(active) else 0.0,
    }
    if policy == "adaptive_qp":
        stats = compute_metrics(recordings[-1])
        for key in (
            "qp_model_ms_median",
            "qp_build_ms_median",
            "qp_solve_ms_median",
            "qp_solve_ms_p99",
            "qp_step_ms_median",
            "qp_step_ms_p99",
        ):
            figures[key + suffix] = float(stats[key])
    return figures


def reshape_figures(repeats: int) -> dict[str, float]:
    """The reshaping QP's whole step and its solver's part (ms; median and p99 over the steps of one episode, the
    median of those over `repeats` episodes) with each solver."""
    figures = {}
    for solver in QP_SOLVERS:
        simulate_named(
            with_qp_solver(RESHAPE_PUSH, solver), "stiff", "reshape"
        )  # warm-up, as in policy_figures
        steps = []
        for _ in range(repeats):
            stats = compute_metrics(simulate_named(with_qp_solver(RESHAPE_PUSH, solver), "stiff", "reshape"))
            steps.append(
                (
                    stats["preimpact_qp_ms_median"],
                    stats["preimpact_qp_ms_p99"],
                    stats["preimpact_qp_solve_ms_median"],
                    stats["preimpact_qp_solve_ms_p99"],
                    stats["preimpact_qp_steps"],
                )
            )
        median, p99, solve_median, solve_p99, count = (statistics.median(column) for column in zip(*steps))
        x = _suffix(solver)
        figures |= {
            f"reshape_step_ms_median{x}": median,
            f"reshape_step_ms_p99{x}": p99,
            f"reshape_solve_ms_median{x}": solve_median,
            f"reshape_solve_ms_p99{x}": solve_p99,
            f"reshape_steps{x}": count,
        }
    return figures


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


def _sweep_file(runs: int, folder: Path) -> Path:
    """A scenario file of runs / 4 points, drops and pushes in turn from the shipped files."""
    from ruamel.yaml import YAML

    shipped = Path(__file__).resolve().parents[2] / "scenarios"
    default = Scenario.model_fields["robot"].default  # the bench's sweep: one robot
    drops, pushes = (
        [
            p
            for p in load([shipped / name])
            if p.scenario.robot == default and p.scenario.physics_dt == DEFAULT_PHYSICS_DT
        ]
        for name in ("drop.yaml", "push.yaml")
    )
    mixed = [p for pair in zip(drops, pushes) for p in pair] + drops[len(pushes) :] + pushes[len(drops) :]
    if runs // 4 > len(mixed):
        raise ValueError(
            f"--e2e-runs {runs}: the shipped drops and pushes give at most {4 * len(mixed)} runs"
        )
    documents = [
        p.scenario.model_dump(mode="json", exclude_defaults=True) | {"name": f"{p.scenario.name}_{i}"}
        for i, p in enumerate(mixed[: runs // 4])
    ]
    path = folder / f"sweep{runs}.yaml"
    with open(path, "w") as handle:
        YAML(typ="safe", pure=True).dump_all(documents, handle)
    return path


def _command_s(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def _e2e_sweep_figures(
    cli: list[str],
    runs: int,
    folder: Path,
    sweep_repeats: int,
    progress: Callable[[str], None],
) -> dict[str, float]:
    """`run sweep` of `runs` shipped runs with 1 and 2 jobs in turn, `sweep_repeats` pairs: median
    wall times (s) and the median of the pairs' speedups."""
    path = _sweep_file(runs, folder)
    times: dict[int, list[float]] = {1: [], 2: []}
    for repeat in range(sweep_repeats):
        for jobs in (1, 2):
            progress(f"whole command: {runs}-run sweep, {jobs} job(s), pair {repeat + 1}/{sweep_repeats}")
            results = folder / f"r{runs}-{jobs}-{repeat}"
            times[jobs].append(
                _command_s(
                    cli
                    + [
                        "run",
                        "sweep",
                        str(path),
                        "--jobs",
                        str(jobs),
                        "--pre-impact",
                        "none",
                        "--results",
                        str(results),
                        "--reports",
                        str(results / "rep"),
                        "--no-progress",
                    ]
                )
            )
    figures = {f"e2e_sweep_s_{jobs}job_{runs}": statistics.median(times[jobs]) for jobs in (1, 2)}
    figures[f"e2e_speedup_{runs}"] = statistics.median(a / b for a, b in zip(times[1], times[2]))
    return figures


def _run_one_s(cli: list[str], point: ScenarioPoint, index: int, folder: Path, repeats: int) -> float:
    """Median wall time (s) of `run one` on the point (`index` in its file) with `stiff`, each into
    a fresh store."""
    return statistics.median(
        _command_s(
            cli
            + [
                "run",
                "one",
                point.source,
                "--point",
                str(index),
                "--policy",
                "stiff",
                "--results",
                str(folder / f"one{i}"),
            ]
        )
        for i in range(repeats)
    )


def _import_s(repeats: int) -> float:
    """Median time (s) a fresh interpreter takes to import the modules `run one` loads."""
    probe = (
        "import time; t = time.perf_counter(); import fallbench.cli, fallbench.results.runner, fallbench.sim.episode, "
        "fallbench.analysis.metrics; print(time.perf_counter() - t)"
    )
    return statistics.median(
        float(
            subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True).stdout
        )
        for _ in range(repeats)
    )


def command_figures(
    point: ScenarioPoint,
    runs_list: list[int],
    repeats: int,
    sweep_repeats: int,
    progress: Callable[[str], None],
) -> dict[str, float]:
    """Whole commands in fresh interpreters: sweeps with 1 and 2 jobs (in turn, `sweep_repeats`
    pairs, medians), `run one` on the point with `stiff`, and the import time of `run one`'s modules."""
    cli = [sys.executable, "-m", "fallbench.cli"]
    index = next(i for i, p in enumerate(load([point.source])) if p.label == point.label)
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        for runs in runs_list:
            figures.update(_e2e_sweep_figures(cli, runs, Path(folder), sweep_repeats, progress))
        progress("whole command: run one")
        figures["run_one_s"] = _run_one_s(cli, point, index, Path(folder), repeats)
    figures["import_s"] = _import_s(repeats)
    return figures


def report_figures(results: Path, jobs: int, progress: Callable[[str], None]) -> dict[str, float]:
    """`fallbench report` of the store `results` as a whole command (fresh interpreter, start-up
    included) with `jobs` drawing processes: cold into an empty folder, then warm into the same
    folder (every figure's runs unchanged, so none is drawn again)."""
    cli = [sys.executable, "-m", "fallbench.cli", "report", "--results", str(results), "--no-progress"]
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "report"
        command = cli + ["--out", str(out), "--jobs", str(jobs)]
        progress(f"report of {results}: cold")
        cold = _command_s(command)
        progress(f"report of {results}: warm")
        warm = _command_s(command)
        files = sum(1 for p in out.iterdir() if not p.name.startswith("."))
    return {"report_jobs": jobs, "report_cold_s": cold, "report_warm_s": warm, "report_files": files}


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
        figures["store_query_s_median"] = _median_time(lambda: store.query(results, GROUPED_QUERY), repeats)
        figures["store_filtered_read_s_median"] = _median_time(
            lambda: store.load_metrics(results, scenario=["scenario_3"], policy=["stiff"]), repeats
        )
        figures["store_parts"] = len(list((results / store.TABLE).glob("part-*.parquet")))
        figures["store_table_mb"] = sum(p.stat().st_size for p in (results / store.TABLE).iterdir()) / 1e6
    return figures


def environment_figures(scenario: Path, robot: str | None, episodes: int) -> dict[str, float]:
    """`fallbench/Fall-v0` on `scenario`: `episodes` whole episodes (reset seeds 0, 1, ...) of
    uniform random actions (drawn outside the timing). env_overhead = wall time of the step calls /
    time those steps spent in mj_step - 1. Empty without gymnasium (the `learned` extra)."""
    import importlib.util

    if importlib.util.find_spec("gymnasium") is None:
        return {}
    from fallbench.environment.fall import FallEnv

    env = FallEnv(scenario, robot)
    env.action_space.seed(0)
    env.reset(seed=0)  # first world compile and imports, not counted
    wall = physics = 0.0
    steps = 0
    for seed in range(episodes):
        env.reset(seed=seed)
        assert env.episode is not None
        before, done = env.episode.physics_s, False
        while not done:
            action = env.action_space.sample()
            started = time.perf_counter()
            _, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated  # an episode that reaches its cap is truncated
            wall += time.perf_counter() - started
            steps += 1
        physics += env.episode.physics_s - before
    return {
        "env_episodes": episodes,
        "env_steps": steps,
        "env_steps_per_s": steps / wall,
        "env_step_ms": wall / steps * 1e3,
        "env_physics_ms_per_step": physics / steps * 1e3,
        "env_overhead": wall / physics - 1.0,
    }


def _environment_lines(figures: dict[str, Any]) -> list[str]:
    if "env_steps" not in figures:
        return []
    return [
        f"Gymnasium environment `fallbench/Fall-v0` on `{figures['env_scenario']}` ({figures['env_episodes']} "
        f"episodes of random actions, {figures['env_steps']} steps): {figures['env_steps_per_s']:.0f} steps/s, "
        f"{figures['env_step_ms']:.2f} ms per step of which {figures['env_physics_ms_per_step']:.2f} ms in mj_step: "
        f"the environment adds {figures['env_overhead'] * 100:.0f} % to its physics.",
        "",
    ]


def run_bench(
    point: ScenarioPoint,
    pre_impact: str = "none",
    repeats: int = 5,
    sweep_runs: int = 48,
    progress: Callable[[str], None] = lambda message: None,
    store_runs: int = 100_000,
    e2e_runs: tuple[int, ...] = (20, 100),
    e2e_repeats: int = 1,
    env_scenario: Path | None = None,
    env_robot: str | None = None,
    env_episodes: int = 4,
    report_store: Path | None = None,
    report_jobs: int = 2,
) -> dict[str, Any]:
    """Every figure as one flat dict (keys documented in docs/bench.md); `store_runs` 0, an empty
    `e2e_runs` or no `env_scenario` leaves those parts out; `report_store`: a results store whose
    report is timed."""
    figures: dict[str, Any] = {"scenario": point.label, "pre_impact": pre_impact, "cpu_count": os.cpu_count()}
    progress("warming up")
    warm = simulate_named(point.scenario, "stiff", pre_impact)
    figures["physics_steps"] = warm.steps
    progress("pure physics")
    physics = _median_time(lambda: pure_physics_s(point, warm.steps), repeats)
    figures["physics_s"] = physics
    figures["physics_steps_per_s"] = warm.steps / physics
    for policy in FIXED:
        progress(f"episode: {policy}")
        figures.update(policy_figures(point.scenario, policy, pre_impact, repeats, physics))
    for solver in QP_SOLVERS:
        progress(f"episode: adaptive_qp ({solver})")
        figures.update(
            policy_figures(
                with_qp_solver(point.scenario, solver),
                "adaptive_qp",
                pre_impact,
                max(2, repeats // 2),
                physics,
                _suffix(solver),
            )
        )
    progress("reshaping QP step")
    figures.update(reshape_figures(max(2, repeats // 2)))
    progress(f"sweep: {sweep_runs} runs with 1 and 2 jobs")
    figures.update(sweep_figures(sweep_specs(point, sweep_runs, pre_impact)))
    if store_runs:
        figures.update(
            store_figures(simulate(RunSpec(point, "stiff", pre_impact)), store_runs, repeats, progress)
        )
    figures.update(command_figures(point, list(e2e_runs), repeats, e2e_repeats, progress))
    if env_scenario is not None:
        progress(f"Gymnasium environment: {env_episodes} episodes of {env_scenario}")
        env = environment_figures(env_scenario, env_robot, env_episodes)
        figures.update(env | ({"env_scenario": str(env_scenario)} if env else {}))
    if report_store is not None:
        figures.update(report_figures(report_store, report_jobs, progress))
    for key, comparison, limit in TARGETS.values():
        if key in figures:
            value = figures[key]
            figures[f"target_met:{key}"] = bool(value <= limit if comparison == "<=" else value >= limit)
    return figures


def _policy_lines(figures: dict[str, Any]) -> list[str]:
    """The heading, pure physics, and one table row per policy (adaptive_qp once per QP solver)."""
    lines = [
        "# fallbench bench",
        "",
        f"Scenario `{figures['scenario']}`, pre-impact `{figures['pre_impact']}`, {figures['cpu_count']} CPUs. "
        f"Pure physics: {figures['physics_steps']} steps in {figures['physics_s'] * 1e3:.1f} ms "
        f"= {figures['physics_steps_per_s']:,.0f} steps/s.",
        "",
        "| policy | episode (ms) | / pure physics | / its own physics | controller per step median (ms) | p99 (ms) |",
        "|---|---|---|---|---|---|",
    ]
    rows = [(p, p) for p in FIXED] + [
        (f"adaptive_qp ({solver})", "adaptive_qp" + _suffix(solver)) for solver in QP_SOLVERS
    ]
    for label, p in rows:
        lines.append(
            f"| {label} | {figures[f'episode_s_{p}'] * 1e3:.1f} | {figures[f'episode_ratio_{p}']:.2f} | "
            f"{figures[f'episode_ratio_own_physics_{p}']:.2f} | {figures[f'controller_ms_median_{p}']:.3f} | "
            f"{figures[f'controller_ms_p99_{p}']:.3f} |"
        )
    lines.append("")
    return lines


def _qp_lines(figures: dict[str, Any]) -> list[str]:
    """Per QP solver: adaptive_qp's QP step in parts, and the reshaping QP's step."""
    lines = []
    for solver in QP_SOLVERS:
        x = _suffix(solver)
        lines += [
            f"adaptive_qp per QP step with {solver} (medians): model {figures['qp_model_ms_median' + x]:.3f} ms, build "
            f"{figures['qp_build_ms_median' + x]:.3f} ms, solve {figures['qp_solve_ms_median' + x]:.3f} ms; whole step median "
            f"{figures['qp_step_ms_median' + x]:.3f} ms, p99 {figures['qp_step_ms_p99' + x]:.3f} ms; the solver alone: p99 "
            f"{figures['qp_solve_ms_p99' + x]:.3f} ms. Reshaping QP step with {solver} (`{RESHAPE_PUSH.name}`, "
            f"{figures['reshape_steps' + x]:.0f} steps): median {figures['reshape_step_ms_median' + x]:.3f} ms, p99 "
            f"{figures['reshape_step_ms_p99' + x]:.3f} ms; the solver alone: median {figures['reshape_solve_ms_median' + x]:.3f} ms, "
            f"p99 {figures['reshape_solve_ms_p99' + x]:.3f} ms.",
            "",
        ]
    return lines


def _sweep_lines(figures: dict[str, Any]) -> list[str]:
    """Sweep throughput and memory, then the whole commands measured."""
    lines = [
        f"Sweep of {figures['sweep_runs']} runs (4 policies): 1 job {figures['sweep_runs_per_s_1job']:.2f} runs/s, "
        f"2 jobs {figures['sweep_runs_per_s_2job']:.2f} runs/s, speedup {figures['sweep_speedup']:.2f}x "
        f"(worker start and model compile {figures['worker_warmup_s']:.1f} s, not counted). Peak RSS: workers "
        f"{figures['worker_peak_rss_mb']:.0f} MB, main process {figures['main_peak_rss_mb']:.0f} MB. "
        f"Stored per run: {figures['bytes_per_run'] / 1024:.0f} KiB"
        + (
            f" (--timeseries landing; full {figures['bytes_per_run_full'] / 1024:.0f} KiB, "
            f"none {figures['bytes_per_run_none'] / 1024:.1f} KiB)."
            if "bytes_per_run_full" in figures
            else "."
        ),
        "",
    ]
    for runs in sorted(int(k.rsplit("_", 1)[1]) for k in figures if k.startswith("e2e_speedup_")):
        lines += [
            f"Whole command, {runs}-run sweep of shipped drops and pushes (4 policies, no reshaping), start-up "
            f"included: 1 job {figures[f'e2e_sweep_s_1job_{runs}']:.2f} s, 2 jobs {figures[f'e2e_sweep_s_2job_{runs}']:.2f} s, "
            f"speedup {figures[f'e2e_speedup_{runs}']:.2f}x.",
            "",
        ]
    if "run_one_s" in figures:
        lines += [
            f"`fallbench run one` (stiff, whole command): {figures['run_one_s']:.2f} s, of which imports "
            f"{figures['import_s']:.2f} s.",
            "",
        ]
    return lines


def _store_lines(figures: dict[str, Any]) -> list[str]:
    """The results store's timings at N runs, when measured."""
    if "store_runs" not in figures:
        return []
    return [
        f"Results store of {figures['store_runs']:,} runs ({figures['store_parts']} parts, "
        f"{figures['store_table_mb']:.1f} MB; built in {figures['store_build_s']:.1f} s): adding one run "
        f"median {figures['store_add_one_s_median']:.3f} s, worst {figures['store_add_one_s_max']:.3f} s; "
        f"grouped query {figures['store_query_s_median']:.3f} s; filtered read (one scenario, one policy) "
        f"{figures['store_filtered_read_s_median']:.3f} s.",
        "",
    ]


def _report_lines(figures: dict[str, Any]) -> list[str]:
    """The report's time, cold and warm, when measured."""
    if "report_cold_s" not in figures:
        return []
    return [
        f"`fallbench report` ({figures['report_jobs']} jobs, whole command, {figures['report_files']} files): "
        f"cold {figures['report_cold_s']:.1f} s, warm (no run changed) {figures['report_warm_s']:.1f} s.",
        "",
    ]


def _target_lines(figures: dict[str, Any]) -> list[str]:
    """The targets table: each measured figure against its limit."""
    lines = ["| target | measured | of which the QP solver alone | limit | met |", "|---|---|---|---|---|"]
    for name, (key, comparison, limit) in TARGETS.items():
        share = f"{figures[SOLVER_SHARE[key]]:.3g}" if SOLVER_SHARE.get(key) in figures else ""
        if key in figures:
            lines.append(
                f"| {name} | {figures[key]:.3g} | {share} | {comparison} {limit:g} | {'yes' if figures[f'target_met:{key}'] else 'NO'} |"
            )
        else:
            lines.append(f"| {name} | not measured | | {comparison} {limit:g} | - |")
    return lines


def markdown(figures: dict[str, Any]) -> str:
    """The figures of `run_bench` as the Markdown of reports/bench.md."""
    lines = _policy_lines(figures) + _qp_lines(figures) + _sweep_lines(figures) + _store_lines(figures)
    lines += _environment_lines(figures)
    lines += _report_lines(figures)
    return "\n".join(lines + _target_lines(figures)) + "\n"
