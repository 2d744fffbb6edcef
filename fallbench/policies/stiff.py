"""`stiff`: keep the default high PD gains after impact (002 Sec. VI, method 1)."""

from __future__ import annotations

import numpy as np

from fallbench.policies.base import GainPolicy, Observation, hold
from fallbench.servo import ServoCommand


class StiffPolicy(GainPolicy):
    name = "stiff"

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        return ServoCommand(self.default_kp, self.default_kd, q_ref, hold(q_ref))
