"""Points fixed in a robot body: world positions, Jacobians and drifts (shared by the point tasks
and the contact points)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics import kernels

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
ONE_BODY = np.zeros(1, dtype=np.int64)  # body_of of a single point


def bodies_points_kinematics(
    model: pin.Model, data: pin.Data, frames: list[int], body_of: np.ndarray, offsets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (m, 3, nv) and drifts (m, 3) of m points on several bodies: point i is fixed in the
    body of frame id frames[body_of[i]], at world-frame offset offsets[i] (m) from its origin. One frame
    Jacobian, velocity and acceleration per body from Pinocchio, then all points in one kernel.

    Needs forwardKinematics(q, v, 0), computeJointJacobians(q) and updateFramePlacements.
    """
    J6 = np.array([pin.getFrameJacobian(model, data, frame, LWA) for frame in frames])  # (bodies, 6, nv)
    omega = np.array([pin.getFrameVelocity(model, data, frame, LWA).angular for frame in frames])
    acceleration = np.array(
        [pin.getFrameClassicalAcceleration(model, data, frame, LWA).vector for frame in frames]
    )
    return kernels.points_kinematics(
        J6, omega, acceleration, body_of, np.ascontiguousarray(offsets, dtype=float)
    )


@dataclass
class BodyPoint:
    frame: str  # Pinocchio frame of the body
    local: np.ndarray  # m, in the body frame

    def kinematics(self, model: pin.Model, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, Jacobian (3, nv), drift J_dot q_dot) in the world frame."""
        frame = model.getFrameId(self.frame)
        placement = data.oMf[frame]
        offset = placement.rotation @ self.local
        jacobians, drifts = bodies_points_kinematics(model, data, [frame], ONE_BODY, offset[None, :])
        return placement.translation + offset, jacobians[0], drifts[0]
