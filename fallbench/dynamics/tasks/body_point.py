"""Points fixed in a robot body: world positions, Jacobians and drifts (shared by the point tasks
and the contact points)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


# vec([v]x) = v @ _SKEW: each entry of a cross-product matrix is +-one component of v (exact)
_SKEW = np.zeros((3, 9))
_SKEW[2, 1], _SKEW[1, 2], _SKEW[0, 5] = -1.0, 1.0, -1.0
_SKEW[2, 3], _SKEW[1, 6], _SKEW[0, 7] = 1.0, -1.0, 1.0


def skew_stack(vectors: np.ndarray) -> np.ndarray:
    """(m, 3, 3) cross-product matrices [v]x of m vectors (np.cross is slow on small arrays)."""
    return (vectors @ _SKEW).reshape(len(vectors), 3, 3)


def points_kinematics(model: pin.Model, data: pin.Data, frame: str, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (m, 3, nv) and drifts J_dot q_dot (m, 3) of m points of one body, given as world-frame
    offsets (m, 3) from the body's origin.

    Needs forwardKinematics(q, v, 0), computeJointJacobians(q) and updateFramePlacements.
    """
    return bodies_points_kinematics(model, data, [model.getFrameId(frame)], np.zeros(len(offsets), dtype=int), offsets)


def bodies_points_kinematics(model: pin.Model, data: pin.Data, frames: list[int], body_of: np.ndarray,
                             offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (m, 3, nv) and drifts (m, 3) of m points on several bodies: point i is fixed in the
    body of frame id frames[body_of[i]], at world-frame offset offsets[i] (m) from its origin. One frame
    Jacobian, velocity and acceleration per body, then one batched product for all points."""
    J6 = np.array([pin.getFrameJacobian(model, data, frame, LWA) for frame in frames])  # (bodies, 6, nv)
    omega = np.array([pin.getFrameVelocity(model, data, frame, LWA).angular for frame in frames])
    acc = np.array([pin.getFrameClassicalAcceleration(model, data, frame, LWA).vector for frame in frames])
    # v_p = v + omega x r = v - [r]x omega;  a_p = a - [r]x alpha + omega x (omega x r)
    R = skew_stack(offsets)
    jacobians = J6[body_of, :3] - R @ J6[body_of, 3:]
    omega_x = skew_stack(omega)
    centripetal = (omega_x @ omega_x)[body_of] @ offsets[:, :, None]
    drifts = acc[body_of, :3] - (R @ acc[body_of, 3:, None])[:, :, 0] + centripetal[:, :, 0]
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
