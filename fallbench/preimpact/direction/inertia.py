"""Inertia shaping about the centre of pressure (004 Sec. IV-B-2, Fig. 5, eqs. 6-8).

I^P is the composite-rigid-body inertia of the whole robot about a fixed ground point P (the CoP),
world axes; I_hat its 6 unique entries (xx, yy, zz, xy, xz, yz). Its Jacobian J_I (d I_hat = J_I
d theta) is analytic: moving joint k turns one part of the robot about the joint's axis, the
subtree beyond the joint, or, for a joint between the root and the stance foot (which stays on
the ground), everything but that subtree, the other way. The desired inertia I_d is the smallest
symmetric change of I^P that makes the present angular momentum about P spin the robot toward the
desired direction (004 takes I_d from [1], which this reading does not have; see docs/methods/direction.md).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.vectors import UP, cross

UNIQUE = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def to_vector(inertia: np.ndarray) -> np.ndarray:
    """I (3, 3) -> I_hat (6,)."""
    return np.array([inertia[i, j] for i, j in UNIQUE])


def point_mass_term(offset: np.ndarray) -> np.ndarray:
    """D(d) = |d|^2 E - d d^T: a unit point mass's inertia about a point at -d from it."""
    return float(offset @ offset) * np.eye(3) - np.outer(offset, offset)


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def inertia_about(
    model: pin.Model, data: pin.Data, q: np.ndarray, v: np.ndarray, point: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(I^P (3, 3) kg m^2, L_P (3,) kg m^2/s angular momentum about P). Runs ccrba: fills data.com,
    data.hg, data.Ig and the world-frame subtree inertias data.oYcrb."""
    pin.ccrba(model, data, q, v)
    mass, com = data.Ig.mass, data.com[0]
    offset = com - point
    inertia = data.Ig.inertia + mass * point_mass_term(offset)
    momentum = data.hg.angular + cross(offset, data.hg.linear)
    return inertia, momentum


def _moving_part(data: pin.Data, joint: int, anchored: bool) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, CoM, inertia about the CoM) of what moves with `joint`: its subtree, or when the joint
    is between the root and the anchored foot, the rest of the robot."""
    sub = data.oYcrb[joint]
    if not anchored:
        return sub.mass, sub.lever.copy(), sub.inertia.copy()
    total = data.oYcrb[1]
    mass = total.mass - sub.mass
    moment = total.mass * total.lever - sub.mass * sub.lever
    about_origin = (total.inertia + total.mass * point_mass_term(total.lever)) - (
        sub.inertia + sub.mass * point_mass_term(sub.lever)
    )
    com = moment / mass
    return mass, com, about_origin - mass * point_mass_term(com)


def inertia_jacobian(
    model: pin.Model, data: pin.Data, point: np.ndarray, anchored_joints: set[int]
) -> np.ndarray:
    """J_I (6, nv - 6): d I_hat / d theta per joint, with the stance foot fixed on the ground.

    Needs inertia_about (ccrba) and computeJointJacobians at the same q. `anchored_joints`: the
    joints between the root and the stance foot."""
    columns = np.zeros((6, model.nv - 6))
    for joint in range(2, model.njoints):
        index = model.joints[joint].idx_v
        anchored = joint in anchored_joints
        twist = data.J[:, index] * (
            -1.0 if anchored else 1.0
        )  # world frame, at the origin: (linear, angular)
        linear, angular = twist[:3], twist[3:]
        mass, com, inertia = _moving_part(data, joint, anchored)
        offset = com - point
        velocity = linear + cross(angular, com)
        turn = _skew(angular) @ inertia - inertia @ _skew(angular)
        shift = mass * (
            2.0 * float(offset @ velocity) * np.eye(3)
            - np.outer(velocity, offset)
            - np.outer(offset, velocity)
        )
        columns[:, index - 6] = to_vector(turn + shift)
    return columns


def desired_inertia(inertia: np.ndarray, momentum: np.ndarray, direction: float) -> np.ndarray:
    """I_d (3, 3): the minimum-Frobenius symmetric change of I^P with (I^P + dI) w = L_P, where
    w = |omega_h| (z x u_d) tips the robot toward the desired direction (rad) at the present
    horizontal rate omega_h of omega = (I^P)^-1 L_P."""
    omega = np.linalg.solve(inertia, momentum)
    toward = np.array([np.cos(direction), np.sin(direction), 0.0])
    w = float(np.linalg.norm(omega[:2])) * cross(UP, toward)
    norm2 = float(w @ w)
    if norm2 < 1e-12:
        return inertia.copy()
    error = momentum - inertia @ w
    change = (np.outer(error, w) + np.outer(w, error)) / norm2 - float(error @ w) * np.outer(w, w) / norm2**2
    return inertia + change


def damped_solve(jacobian: np.ndarray, target: np.ndarray, damping: float) -> np.ndarray:
    """J^# target with the damped pseudo-inverse J^T (J J^T + damping^2 E)^-1."""
    gram = jacobian @ jacobian.T + damping**2 * np.eye(len(jacobian))
    return jacobian.T @ np.linalg.solve(gram, target)


def damped_solve_holding(
    jacobian: np.ndarray, target: np.ndarray, held: np.ndarray, damping: float
) -> np.ndarray:
    """J^# target among the velocities that keep `held` (k, n) still: x = N (J N)^# target with N
    the projector onto held's null space (both feet on the ground: their relative twist stays zero)."""
    null = np.eye(held.shape[1]) - np.linalg.pinv(held, rcond=1e-8) @ held
    return null @ damped_solve(jacobian @ null, target, damping)
