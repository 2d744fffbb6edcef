"""Contact limits at acceleration level (the authors' `ContactAccConstr`; 002 eq. 11 bounds the
contact body's velocity instead).

Every contact point's normal acceleration n'(J q_ddot + J_dot q_dot) is zero; tangential motion
is left to a cost (sliding released, 002 Sec. VII). The points of one body are redundant (four
corners of a flat foot give three independent rows), so the rows are combined per body into an
independent set, which keeps the equality block full rank for the solver. (A per-point
inequality, no point accelerating into the floor, was tried: the QP then tipped the feet and the
robot fell from every height.)
"""

from __future__ import annotations

import numpy as np

from fallbench.dynamics.contacts import ContactKinematics, ContactPoint, normal_matrix
from fallbench.dynamics.objective import SetPoint

RANK_TOLERANCE = 1e-6  # relative to a body's largest singular value


def normal_acceleration_rows(points: list[ContactPoint], kinematics: ContactKinematics) -> tuple[np.ndarray, np.ndarray]:
    """(R, r): independent rows with R q_ddot + r = 0 equivalent to zero normal acceleration of every point."""
    nv = kinematics.jacobian.shape[1]
    if not points:
        return np.zeros((0, nv)), np.zeros(0)
    normals = normal_matrix(points)
    rows, drifts = normals @ kinematics.jacobian, normals @ kinematics.drift
    bodies = [p.body for p in points]
    groups = [[i for i, b in enumerate(bodies) if b == body] for body in dict.fromkeys(bodies)]  # first-seen order
    width = max(len(g) for g in groups)
    # one batched SVD for all bodies, each block padded with zero rows (zero singular values)
    stacked = np.zeros((len(groups), width, nv + 1))
    for k, group in enumerate(groups):
        stacked[k, : len(group), :nv], stacked[k, : len(group), nv] = rows[group], drifts[group]
    U, s, _ = np.linalg.svd(stacked[:, :, :nv], full_matrices=False)
    keep = s > RANK_TOLERANCE * s[:, :1]
    combined = np.concatenate([U[k][:, keep[k]].T @ stacked[k] for k in range(len(groups))])
    return combined[:, :nv], combined[:, nv]


def normal_motion_cost(points: list[ContactPoint], kinematics: ContactKinematics, weight: float, dt: float) -> SetPoint:
    """Contact points neither sinking in nor lifting off within one control step, as a cost:
    weight |n'(J q_ddot + J_dot q_dot) + n'v / dt|^2."""
    normals = normal_matrix(points)
    J = normals @ kinematics.jacobian
    return SetPoint(weight, J, np.zeros(len(points)), normals @ kinematics.drift, 0.0, 1.0 / dt)


def tangential_motion_cost(points: list[ContactPoint], kinematics: ContactKinematics, weight: float, dt: float) -> SetPoint:
    """Soft no-slip: weight |T(J q_ddot + J_dot q_dot) + T v / dt|^2, T = I - n n' per point."""
    normals = normal_matrix(points)
    J = kinematics.jacobian - normals.T @ (normals @ kinematics.jacobian)
    drift = kinematics.drift - normals.T @ (normals @ kinematics.drift)
    return SetPoint(weight, J, np.zeros(len(drift)), drift, 0.0, 1.0 / dt)
