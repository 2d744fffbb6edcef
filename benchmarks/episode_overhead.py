"""Controller overhead: a `stiff` 1 m drop episode vs stepping the same model with no controller.

Both in this process, on the same compiled model, for the same number of physics steps; the
median of several repeats of each. Target: ratio <= 1.3.
"""

from __future__ import annotations

import statistics
import time

import mujoco

from fallbench.episode import run_episode
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


def episode(scenario: Scenario) -> tuple[float, int]:
    started = time.perf_counter()
    recording = run_episode(scenario, "stiff")
    return time.perf_counter() - started, recording.steps


def main() -> None:
    scenario = Scenario(name="drop", duration=1.5, initial={"height": 1.0})
    episode(scenario)  # compile and warm up
    runs = [episode(scenario) for _ in range(REPEATS)]
    steps = runs[0][1]
    physics = statistics.median(pure_physics(scenario, steps) for _ in range(REPEATS))
    controlled = statistics.median(t for t, _ in runs)
    print(f"physics only : {physics * 1e3:7.1f} ms for {steps} steps ({steps / physics:,.0f} steps/s)")
    print(f"stiff episode: {controlled * 1e3:7.1f} ms")
    print(f"ratio        : {controlled / physics:.2f} (target <= 1.3)")


if __name__ == "__main__":
    main()
