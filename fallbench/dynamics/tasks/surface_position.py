"""End-effector position task in a surface frame (002 Sec. IV-C.3).

Only the two coordinates along the surface are controlled; the normal one is left to the
relative-distance task, so hands landing on surfaces of different heights stay synchronised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.task import Task, TaskTerms


@dataclass
class SurfacePositionTask(Task):
    point: BodyPoint
    target: np.ndarray  # m, world (the chosen landing point)
    tangents: np.ndarray  # (2, 3) unit rows spanning the surface

    def compute(self, state: RobotState) -> TaskTerms:
        """Error T (p - target) (m), Jacobian T J, drift T J_dot q_dot (m/s^2), all (2,) or (2, nv)."""
        position, J, drift = self.point.kinematics(state)
        return TaskTerms(self.tangents @ (position - self.target), self.tangents @ J, self.tangents @ drift)
