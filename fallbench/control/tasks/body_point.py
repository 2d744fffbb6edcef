"""A point fixed in a robot body: world position, Jacobian and drift (shared by the point tasks)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass
class BodyPoint:
    frame: str  # Pinocchio frame of the body
    local: np.ndarray  # m, in the body frame

    def kinematics(self, model: pin.Model, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, Jacobian (3, nv), drift J_dot q_dot) in the world frame.

        Needs forwardKinematics(q, v, 0), computeJointJacobians(q) and updateFramePlacements.
        """
        frame = model.getFrameId(self.frame)
        placement = data.oMf[frame]
        offset = placement.rotation @ self.local
        J6 = pin.getFrameJacobian(model, data, frame, LWA)
        twist = pin.getFrameVelocity(model, data, frame, LWA)
        acc = pin.getFrameClassicalAcceleration(model, data, frame, LWA)
        omega = twist.angular
        jacobian = J6[:3] - pin.skew(offset) @ J6[3:]
        drift = acc.linear + np.cross(acc.angular, offset) + np.cross(omega, np.cross(omega, offset))
        return placement.translation + offset, jacobian, drift
