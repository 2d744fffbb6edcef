"""`run_bench`: every figure of `fallbench bench`, measured in turn, as one flat dict."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fallbench.assembly import simulate_named
from fallbench.bench.commands import command_figures, report_figures
from fallbench.bench.config import FIXED, judge_targets, median_time, solver_suffix, with_qp_solver
from fallbench.bench.environment import environment_figures
from fallbench.bench.episodes import policy_figures, pure_physics_s, reshape_figures
from fallbench.bench.storage import store_figures
from fallbench.bench.sweep import sweep_figures, sweep_specs
from fallbench.dynamics.dense_qp import QP_SOLVERS
from fallbench.results.runner import RunSpec, simulate
from fallbench.scenario import ScenarioPoint


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
    physics = median_time(lambda: pure_physics_s(point, warm.steps), repeats)
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
                solver_suffix(solver),
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
    judge_targets(figures)
    return figures
