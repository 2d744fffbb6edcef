"""A run put together: the scenario's world with the baseline gains, the gain policy and the
pre-impact strategy registered under the run's names, and the episode that simulates them
(`fallbench.sim.episode`, which knows no strategy or policy by name). The sweep runner calls
`simulate_named` for every run; the Gymnasium environment builds its worlds with `run_world`.
"""

from __future__ import annotations

from fallbench.registry import NO_POLICY, load_policy, load_strategy, run_policy, stat_columns
from fallbench.scenario import Scenario
from fallbench.sim.baseline import gain_scale, with_gain_scale
from fallbench.sim.episode import run_episode
from fallbench.sim.recorder import Recording
from fallbench.sim.settle import ensure_standing_height
from fallbench.sim.world import World, build_world


def run_world(scenario: Scenario) -> World:
    """The world a run simulates: the scenario's, with its default gains times
    `policy_params.stiff.gain_scale`, the baseline stiffness every policy uses before impact
    (and `stiff` after). A standing height the robot's card leaves out is derived first (the
    metrics read it)."""
    ensure_standing_height(scenario.robot)
    return with_gain_scale(build_world(scenario), gain_scale(scenario))


def simulate_named(scenario: Scenario, policy: str, pre_impact: str = "none") -> Recording:
    """One fall under the registered gain policy and pre-impact strategy of these names."""
    if (policy == NO_POLICY) != (run_policy(pre_impact, policy) == NO_POLICY):
        raise ValueError(
            f"policy {policy!r} with strategy {pre_impact!r}: `-` goes with whole-fall strategies only"
        )
    world = run_world(scenario)
    # a whole-fall controller never hands over: its episode is given `stiff`, which never acts
    gain_policy = load_policy("stiff" if policy == NO_POLICY else policy)(world, scenario)
    strategy = load_strategy(pre_impact)(world, scenario)
    return run_episode(world, scenario, gain_policy, strategy, pre_impact, stat_columns())
