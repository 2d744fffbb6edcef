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

from fallbench.dynamics.contacts import ContactKinematics
from fallbench.dynamics.objective import SetPoint

RANK_TOLERANCE = 1e-6  # relative to a body's largest singular value


def normal_acceleration_rows(kinematics: ContactKinematics) -> tuple[np.ndarray, np.ndarray]:
    """(R, r): independent rows with R q_ddot + r = 0 equivalent to zero normal acceleration of every point."""
    body_of, nv = kinematics.body_of, kinematics.jacobian.shape[1]
    if not len(body_of):
        return np.zeros((0, nv)), np.zeros(0)
    # one batched SVD for all bodies: body k's rows (n'J | n' J_dot q_dot) in block k, padded with zero rows
    counts = np.bincount(body_of)
    order = np.argsort(body_of, kind="stable")
    slot = np.empty(len(body_of), dtype=int)
    slot[order] = np.arange(len(body_of)) - np.repeat(np.cumsum(counts) - counts, counts)
    stacked = np.zeros((len(counts), counts.max(), nv + 1))
    stacked[body_of, slot, :nv], stacked[body_of, slot, nv] = kinematics.normal_jacobian, kinematics.normal_drift
    # the left singular vectors of each block, from the eigenvectors of its Gram matrix (a small
    # symmetric eigenproblem is cheaper than an SVD of the wide block); eigenvalues are s^2
    rows = stacked[:, :, :nv]
    eigenvalues, vectors = np.linalg.eigh(rows @ rows.transpose(0, 2, 1))
    keep = eigenvalues > RANK_TOLERANCE**2 * eigenvalues[:, -1:]
    combined = (vectors.transpose(0, 2, 1) @ stacked)[keep]  # body by body, independent rows
    return combined[:, :nv], combined[:, nv]


def normal_motion_cost(kinematics: ContactKinematics, weight: float, dt: float) -> SetPoint:
    """Contact points neither sinking in nor lifting off within one control step, as a cost:
    weight |n'(J q_ddot + J_dot q_dot) + n'v / dt|^2."""
    return SetPoint(weight, kinematics.normal_jacobian, np.zeros(len(kinematics.normals)), kinematics.normal_drift, 0.0, 1.0 / dt)


def tangential_motion_cost(kinematics: ContactKinematics, weight: float, dt: float) -> SetPoint:
    """Soft no-slip: weight |T(J q_ddot + J_dot q_dot) + T v / dt|^2, T = I - n n' per point."""
    normals = kinematics.normals
    J = kinematics.jacobian - (normals[:, :, None] * kinematics.normal_jacobian[:, None, :]).reshape(kinematics.jacobian.shape)
    drift = kinematics.drift - (normals * kinematics.normal_drift[:, None]).reshape(-1)
    return SetPoint(weight, J, np.zeros(len(drift)), drift, 0.0, 1.0 / dt)
