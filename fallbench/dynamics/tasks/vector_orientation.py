"""Vector-orientation task (002 eqs. 3-5): a unit vector fixed in a body toward a world direction.

The reshaping controller uses it to turn the torso's lateral axis perpendicular to the fall
direction, so that the robot meets the ground front or back rather than sideways.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics.vectors import cross

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass
class VectorOrientationTask:
    frame: str  # Pinocchio frame of the body
    body_vector: np.ndarray  # unit, body coordinates
    target: np.ndarray  # unit, world

    def compute(self, model: pin.Model, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(error g = u - u_target, Jacobian dg/dq, drift J_dot q_dot).

        Needs forwardKinematics(q, v, 0), computeJointJacobians(q) and updateFramePlacements on
        `data`. With u = R u_b: u_dot = omega x u, so J = -[u]x J_angular (world-aligned), and
        J_dot q_dot = a_drift x u + omega x (omega x u), a_drift the angular acceleration at q_ddot = 0.
        """
        frame = model.getFrameId(self.frame)
        u = data.oMf[frame].rotation @ self.body_vector
        J_angular = pin.getFrameJacobian(model, data, frame, LWA)[3:]
        omega = pin.getFrameVelocity(model, data, frame, LWA).angular
        alpha = pin.getFrameClassicalAcceleration(model, data, frame, LWA).angular
        jacobian = -pin.skew(u) @ J_angular
        drift = cross(alpha, u) + cross(omega, cross(omega, u))
        return u - self.target, jacobian, drift
