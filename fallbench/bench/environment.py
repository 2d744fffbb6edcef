"""The Gymnasium environment's steps per second against the time its steps spend in mj_step."""

from __future__ import annotations

import time
from pathlib import Path


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
