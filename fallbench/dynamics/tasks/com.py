"""Centre-of-mass task: the CoM toward a set point (world frame, m)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.task import Task, TaskTerms


@dataclass
class ComTask(Task):
    target: np.ndarray  # m, world

    def compute(self, state: RobotState) -> TaskTerms:
        """g = c - c_target (m), the CoM Jacobian and J_com_dot v (m/s^2), from the state's CoM pass."""
        return TaskTerms(state.com - self.target, state.com_jacobian, state.com_drift)
