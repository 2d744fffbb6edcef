"""End-effector position task in a surface frame (002 Sec. IV-C.3).

Only the two coordinates along the surface are controlled; the normal one is left to the
relative-distance task, so hands landing on surfaces of different heights stay synchronised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics.tasks.body_point import BodyPoint


@dataclass
class SurfacePositionTask:
    point: BodyPoint
    target: np.ndarray  # m, world (the chosen landing point)
    tangents: np.ndarray  # (2, 3) unit rows spanning the surface

    def compute(self, model: pin.Model, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(error T (p - target), Jacobian T J, drift T J_dot q_dot), all (2,) or (2, nv)."""
        position, J, drift = self.point.kinematics(model, data)
        return self.tangents @ (position - self.target), self.tangents @ J, self.tangents @ drift
