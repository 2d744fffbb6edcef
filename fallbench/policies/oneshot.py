"""`oneshot`: at impact, P gain / 1000 and D gain / 100, then held (000, Humanoids 2015 Sec. VI)."""

from __future__ import annotations

import numpy as np

from fallbench.policies.base import GainPolicy, Observation, hold
from fallbench.servo import ServoCommand
from fallbench.world import World


class OneshotPolicy(GainPolicy):
    name = "oneshot"
    defaults = {"kp_factor": 1e-3, "kd_factor": 1e-2}

    def __init__(self, world: World, params: dict) -> None:
        super().__init__(world, params)
        self.kp = self.default_kp * float(self.params["kp_factor"])
        self.kd = self.default_kd * float(self.params["kd_factor"])

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        return ServoCommand(self.kp, self.kd, q_ref, hold(q_ref))
