"""Controller overhead: a 1 m drop episode vs stepping the same model with no controller.

Both in this process, on the same compiled model, for the same number of physics steps; the
median of several repeats of each, for every policy. Targets: `stiff` <= 1.3, `adaptive_qp` <= 3;
for `adaptive_qp` also the per-control-step cost (model update + QP build + solve) after impact.
"""

from __future__ import annotations

import statistics
import time

import mujoco

from fallbench.episode import run_episode
from fallbench.metrics import compute_metrics
from fallbench.scenario import Scenario
from fallbench.servo import ServoCommand, write_servo
from fallbench.world import build_world, initial_state

REPEATS = 7


def pure_physics(scenario: Scenario, steps: int) -> float:
    world = build_world(scenario)
    data = initial_state(world, scenario)
    write_servo(world.model, data, ServoCommand(world.default_kp, world.default_kd, data.ctrl.copy(), 0 * data.ctrl))
    started = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(world.model, data)
    return time.perf_counter() - started


POLICIES = ("stiff", "oneshot", "zero", "adaptive_qp")


def episode(scenario: Scenario, policy: str) -> tuple[float, int, dict]:
    started = time.perf_counter()
    recording = run_episode(scenario, policy)
    elapsed = time.perf_counter() - started
    return elapsed, recording.steps, compute_metrics(recording)


def main() -> None:
    scenario = Scenario(name="drop", duration=1.5, initial={"height": 1.0})
    episode(scenario, "stiff")  # compile and warm up
    steps = episode(scenario, "stiff")[1]
    physics = statistics.median(pure_physics(scenario, steps) for _ in range(REPEATS))
    print(f"physics only        : {physics * 1e3:7.1f} ms for {steps} steps ({steps / physics:,.0f} steps/s)")
    for policy in POLICIES:
        runs = [episode(scenario, policy) for _ in range(REPEATS if policy != "adaptive_qp" else 3)]
        wall = statistics.median(t for t, _, _ in runs)
        print(f"{policy:<12} episode: {wall * 1e3:7.1f} ms, ratio {wall / physics:5.2f}")
    qp = runs[-1][2]
    print(f"adaptive_qp step after impact (model + build + solve): median {qp['qp_step_ms_median']:.2f} ms, "
          f"p99 {qp['qp_step_ms_p99']:.2f} ms; model {qp['qp_model_ms_median']:.2f}, build {qp['qp_build_ms_median']:.2f}, "
          f"solve {qp['qp_solve_ms_median']:.2f} ms (medians), {qp['qp_steps']} solves, {qp['qp_failures']} failures")


if __name__ == "__main__":
    main()
