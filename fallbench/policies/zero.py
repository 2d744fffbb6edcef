"""`zero`: servo off at impact, K = B = 0 (002 Sec. VI, method 3)."""

from __future__ import annotations

import numpy as np

from fallbench.policies.base import GainPolicy, Observation, hold
from fallbench.servo import ServoCommand
from fallbench.world import World


class ZeroPolicy(GainPolicy):
    name = "zero"

    def __init__(self, world: World, params: dict) -> None:
        super().__init__(world, params)
        self.zeros = np.zeros_like(self.default_kp)

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        return ServoCommand(self.zeros, self.zeros, q_ref, hold(q_ref))
