"""Points fixed in a robot body: world positions, Jacobians and drifts (shared by the point tasks
and the contact points)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def skew_stack(vectors: np.ndarray) -> np.ndarray:
    """(m, 3, 3) cross-product matrices [v]x of m vectors (np.cross is slow on small arrays)."""
    S = np.zeros((len(vectors), 3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -vectors[:, 2], vectors[:, 1], -vectors[:, 0]
    S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = vectors[:, 2], -vectors[:, 1], vectors[:, 0]
    return S


def points_kinematics(model: pin.Model, data: pin.Data, frame: str, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (m, 3, nv) and drifts J_dot q_dot (m, 3) of m points of one body, given as world-frame
    offsets (m, 3) from the body's origin. One frame Jacobian, velocity and acceleration for all.

    Needs forwardKinematics(q, v, 0), computeJointJacobians(q) and updateFramePlacements.
    """
    frame_id = model.getFrameId(frame)
    J6 = pin.getFrameJacobian(model, data, frame_id, LWA)
    omega = pin.getFrameVelocity(model, data, frame_id, LWA).angular
    acc = pin.getFrameClassicalAcceleration(model, data, frame_id, LWA)
    # v_p = v + omega x r = v - [r]x omega
    R = skew_stack(offsets)
    jacobians = J6[None, :3, :] - R @ J6[3:]
    omega_x = skew_stack(omega[None, :])[0]
    drifts = acc.linear - R @ acc.angular + offsets @ (omega_x @ omega_x).T
    return jacobians, drifts


@dataclass
class BodyPoint:
    frame: str  # Pinocchio frame of the body
    local: np.ndarray  # m, in the body frame

    def kinematics(self, model: pin.Model, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, Jacobian (3, nv), drift J_dot q_dot) in the world frame."""
        placement = data.oMf[model.getFrameId(self.frame)]
        offset = placement.rotation @ self.local
        jacobians, drifts = points_kinematics(model, data, self.frame, offset[None, :])
        return placement.translation + offset, jacobians[0], drifts[0]
