"""Episodes measured in this process: pure physics on the compiled model, each policy's episode and
controller cost, the QP steps of adaptive_qp and of the reshaping QP."""

from __future__ import annotations

import statistics
import time

import mujoco
import numpy as np

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.bench.config import RESHAPE_PUSH, solver_suffix, with_qp_solver
from fallbench.dynamics.dense_qp import QP_SOLVERS
from fallbench.scenario import Scenario, ScenarioPoint
from fallbench.sim.servo import ServoCommand, write_servo
from fallbench.sim.world import build_world, initial_state


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
        x = solver_suffix(solver)
        figures |= {
            f"reshape_step_ms_median{x}": median,
            f"reshape_step_ms_p99{x}": p99,
            f"reshape_solve_ms_median{x}": solve_median,
            f"reshape_solve_ms_p99{x}": solve_p99,
            f"reshape_steps{x}": count,
        }
    return figures
