"""The scenario's push: a horizontal force on a body (the torso unless `push.body` names another)
from `push.start` for `push.duration` s, set at each control step."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from fallbench.scenario import Push, Scenario
from fallbench.sim.world import World


class PushForce:
    """The push's body and wrench (force, no torque), applied while it lasts."""

    def __init__(self, world: World, push: Push) -> None:
        self.push = push
        self.body = world.model.body(push.body or world.robot.torso_body).id
        heading = math.radians(push.direction)
        force = push.force * np.array([math.cos(heading), math.sin(heading), 0.0])
        self.wrench = np.concatenate([force, np.zeros(3)])

    @classmethod
    def of(cls, world: World, scenario: Scenario) -> PushForce | None:
        """The scenario's push, None without one (or a zero force)."""
        push = scenario.push
        return None if push is None or push.force == 0 else cls(world, push)

    def apply(self, data: mujoco.MjData, t: float) -> None:
        """The wrench on the body at `t` (s) while the push lasts, else none."""
        push = self.push
        active = push.start <= t < push.start + push.duration
        data.xfrc_applied[self.body] = self.wrench if active else 0.0
