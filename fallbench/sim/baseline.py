"""The baseline stiffness of a run: the robot's default K and B times the scenario's gain scale.

002 gives no gain values ("very high"), so the baseline stiffness is a parameter of the scenario,
written `policy_params.stiff.gain_scale` (default 1): it sets the default gains of every policy
(before impact for all of them, after impact for `stiff`, which keeps them), so a sweep over it
shows how each policy's comparison with `stiff` depends on how stiff the baseline is. The world a
run simulates carries the scaled gains (`World.default_kp`, `default_kd`).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fallbench.scenario import Scenario
    from fallbench.sim.world import World

GAIN_SCALE_SECTION = "stiff"  # the scale is written under `policy_params.stiff`, the policy that keeps it
GAIN_SCALE_KEY = "gain_scale"
DEFAULT_GAIN_SCALE = 1.0


def gain_scale(scenario: Scenario) -> float:
    """`policy_params.stiff.gain_scale` (default 1): factor on the default K and B of every policy."""
    return float(scenario.policy_params.get(GAIN_SCALE_SECTION, {}).get(GAIN_SCALE_KEY, DEFAULT_GAIN_SCALE))


def with_gain_scale(world: World, scale: float) -> World:
    """`world` with its default gains times `scale` (the same world for 1)."""
    if scale == 1.0:
        return world
    return dataclasses.replace(
        world, default_kp=world.default_kp * scale, default_kd=world.default_kd * scale
    )
