"""Centre-of-mass task: the CoM toward a set point (world frame, m)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass
class ComTask:
    target: np.ndarray  # m, world

    @staticmethod
    def state(
        model: pin.Model, data: pin.Data, q: np.ndarray, v: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(CoM position, CoM velocity, drift J_dot v) from one pass with zero acceleration."""
        pin.centerOfMass(model, data, q, v, np.zeros(model.nv))
        return data.com[0].copy(), data.vcom[0].copy(), data.acom[0].copy()

    def error(self, com: np.ndarray) -> np.ndarray:
        """g = c - c_target (m)."""
        return com - self.target

    @staticmethod
    def jacobian(model: pin.Model, data: pin.Data, q: np.ndarray) -> np.ndarray:
        return pin.jacobianCenterOfMass(model, data, q)
