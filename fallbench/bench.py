"""`fallbench bench`: fallbench's cost against the physics limit, 2-core sweep scaling, memory.

Everything is measured in one process on the same compiled model, medians of repeats:
- pure physics: mj_step on the scenario's model with the default servo and no controller;
- per policy: episode wall time / pure-physics wall time for the same number of steps, and
  / the time the episode itself spent in mj_step (a collapsing robot has more contacts, so its
  physics costs more than the standing robot's; the second ratio is the controller's overhead);
- controller cost per control step where a controller ran, and the QP's model/build/solve parts;
- sweep throughput with 1 and 2 jobs on the same run list (warm workers), peak RSS per worker,
  and bytes stored per run.
"""

from __future__ import annotations

import os
import resource
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np
from joblib import Parallel, delayed

from fallbench.episode import run_episode
from fallbench.metrics import compute_metrics
from fallbench.runner import Outcome, RunSpec, expected_cost, simulate, store_outcome
from fallbench.scenario import ScenarioPoint
from fallbench.servo import ServoCommand, write_servo
from fallbench.world import build_world, initial_state

POLICIES = ("stiff", "oneshot", "zero", "adaptive_qp")
FIXED = ("stiff", "oneshot", "zero")

# target name -> (figure key, comparison, limit), from the issue that set them
TARGETS: dict[str, tuple[str, str, float]] = {
    **{f"{p} episode / pure physics": (f"episode_ratio_{p}", "<=", 1.15) for p in FIXED},
    "adaptive_qp episode / pure physics": ("episode_ratio_adaptive_qp", "<=", 2.0),
    "adaptive_qp QP step median (ms)": ("qp_step_ms_median", "<=", 0.3),
    "adaptive_qp QP step p99 (ms)": ("qp_step_ms_p99", "<=", 1.0),
    "2-job / 1-job sweep throughput": ("sweep_speedup", ">=", 1.8),
    "worker peak RSS (MB)": ("worker_peak_rss_mb", "<=", 500.0),
}


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
    write_servo(world.model, data, ServoCommand(world.default_kp, world.default_kd, data.ctrl.copy(), 0 * data.ctrl))
    started = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(world.model, data)
    return time.perf_counter() - started


def policy_figures(point: ScenarioPoint, policy: str, pre_impact: str, repeats: int, physics_s: float) -> dict[str, float]:
    walls, own, recordings = [], [], []
    for _ in range(repeats):
        started = time.perf_counter()
        recording = run_episode(point.scenario, policy, pre_impact)
        walls.append(time.perf_counter() - started)
        own.append(recording.physics_s)
        recordings.append(recording)
    wall = statistics.median(walls)
    active = np.concatenate([r.controller_ms[r.controller_ms > 0] for r in recordings])
    figures = {
        f"episode_s_{policy}": wall,
        f"episode_ratio_{policy}": wall / physics_s,
        f"episode_ratio_own_physics_{policy}": wall / statistics.median(own),
        f"controller_ms_median_{policy}": float(np.median(active)) if len(active) else 0.0,
        f"controller_ms_p99_{policy}": float(np.percentile(active, 99)) if len(active) else 0.0,
    }
    if policy == "adaptive_qp":
        stats = compute_metrics(recordings[-1])
        for key in ("qp_model_ms_median", "qp_build_ms_median", "qp_solve_ms_median", "qp_step_ms_median", "qp_step_ms_p99"):
            figures[key] = float(stats[key])
    return figures


def _simulate_measured(spec: RunSpec) -> tuple[Outcome, int, float]:
    """simulate() in a worker, with the worker's pid and its peak RSS so far (MB)."""
    outcome = simulate(spec)
    return outcome, os.getpid(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def sweep_figures(specs: list[RunSpec]) -> dict[str, float]:
    """Runs/s with 1 job (this process) and 2 loky workers (warmed up first), storing every run."""
    figures: dict[str, float] = {"sweep_runs": len(specs)}
    specs = sorted(specs, key=expected_cost, reverse=True)  # as run_sweep orders them
    peaks: dict[int, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        for jobs in (1, 2):
            results = Path(folder) / f"jobs{jobs}"
            parallel = Parallel(n_jobs=jobs, backend="loky" if jobs > 1 else "sequential", return_as="generator_unordered")
            if jobs > 1:
                started = time.perf_counter()
                warm = [replace(specs[0], point=_with_seed(specs[0].point, 10_000 + i)) for i in range(jobs)]
                list(parallel(delayed(_simulate_measured)(s) for s in warm))
                figures["worker_warmup_s"] = time.perf_counter() - started
            started = time.perf_counter()
            for outcome, pid, peak in parallel(delayed(_simulate_measured)(s) for s in specs):
                store_outcome(results, outcome)
                if jobs > 1:
                    peaks[pid] = max(peaks.get(pid, 0.0), peak)
            figures[f"sweep_runs_per_s_{jobs}job"] = len(specs) / (time.perf_counter() - started)
        stored = [sum(f.stat().st_size for f in run.iterdir()) for run in (Path(folder) / "jobs1" / "runs").iterdir()]
        figures["bytes_per_run"] = float(np.mean(stored))
    figures["sweep_speedup"] = figures["sweep_runs_per_s_2job"] / figures["sweep_runs_per_s_1job"]
    figures["worker_peak_rss_mb"] = max(peaks.values())
    figures["main_peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return figures


def sweep_specs(point: ScenarioPoint, runs: int, pre_impact: str) -> list[RunSpec]:
    """`runs` distinct runs of the point (seeds 0..), cycling through the four policies."""
    return [RunSpec(_with_seed(point, i // len(POLICIES)), POLICIES[i % len(POLICIES)], pre_impact) for i in range(runs)]


def _with_seed(point: ScenarioPoint, seed: int) -> ScenarioPoint:
    """The same point as a distinct run (its own run id) with the same work."""
    return replace(point, scenario=point.scenario.model_copy(update={"seed": seed}))


def run_bench(point: ScenarioPoint, pre_impact: str = "none", repeats: int = 5, sweep_runs: int = 48,
              progress: Callable[[str], None] = lambda message: None) -> dict[str, Any]:
    """Every figure as one flat dict (keys documented in the README)."""
    figures: dict[str, Any] = {"scenario": point.label, "pre_impact": pre_impact, "cpu_count": os.cpu_count()}
    progress("warming up")
    warm = run_episode(point.scenario, "stiff", pre_impact)
    figures["physics_steps"] = warm.steps
    progress("pure physics")
    physics = _median_time(lambda: pure_physics_s(point, warm.steps), repeats)
    figures["physics_s"] = physics
    figures["physics_steps_per_s"] = warm.steps / physics
    for policy in POLICIES:
        progress(f"episode: {policy}")
        figures.update(policy_figures(point, policy, pre_impact, repeats if policy in FIXED else max(2, repeats // 2), physics))
    progress(f"sweep: {sweep_runs} runs with 1 and 2 jobs")
    figures.update(sweep_figures(sweep_specs(point, sweep_runs, pre_impact)))
    for name, (key, comparison, limit) in TARGETS.items():
        value = figures[key]
        figures[f"target_met:{key}"] = bool(value <= limit if comparison == "<=" else value >= limit)
    return figures


def markdown(figures: dict[str, Any]) -> str:
    lines = ["# fallbench bench", "",
             f"Scenario `{figures['scenario']}`, pre-impact `{figures['pre_impact']}`, {figures['cpu_count']} CPUs. "
             f"Pure physics: {figures['physics_steps']} steps in {figures['physics_s'] * 1e3:.1f} ms "
             f"= {figures['physics_steps_per_s']:,.0f} steps/s.", "",
             "| policy | episode (ms) | / pure physics | / its own physics | controller per step median (ms) | p99 (ms) |",
             "|---|---|---|---|---|---|"]
    for p in POLICIES:
        lines.append(f"| {p} | {figures[f'episode_s_{p}'] * 1e3:.1f} | {figures[f'episode_ratio_{p}']:.2f} | "
                     f"{figures[f'episode_ratio_own_physics_{p}']:.2f} | {figures[f'controller_ms_median_{p}']:.3f} | "
                     f"{figures[f'controller_ms_p99_{p}']:.3f} |")
    lines += ["", f"adaptive_qp per QP step (medians): model {figures['qp_model_ms_median']:.3f} ms, build "
              f"{figures['qp_build_ms_median']:.3f} ms, solve {figures['qp_solve_ms_median']:.3f} ms; whole step median "
              f"{figures['qp_step_ms_median']:.3f} ms, p99 {figures['qp_step_ms_p99']:.3f} ms.", "",
              f"Sweep of {figures['sweep_runs']} runs (4 policies): 1 job {figures['sweep_runs_per_s_1job']:.2f} runs/s, "
              f"2 jobs {figures['sweep_runs_per_s_2job']:.2f} runs/s, speedup {figures['sweep_speedup']:.2f}x "
              f"(worker start and model compile {figures['worker_warmup_s']:.1f} s, not counted). Peak RSS: workers "
              f"{figures['worker_peak_rss_mb']:.0f} MB, main process {figures['main_peak_rss_mb']:.0f} MB. "
              f"Stored per run: {figures['bytes_per_run'] / 1024:.0f} KiB.", "",
              "| target | measured | limit | met |", "|---|---|---|---|"]
    for name, (key, comparison, limit) in TARGETS.items():
        lines.append(f"| {name} | {figures[key]:.3g} | {comparison} {limit:g} | {'yes' if figures[f'target_met:{key}'] else 'NO'} |")
    return "\n".join(lines) + "\n"
