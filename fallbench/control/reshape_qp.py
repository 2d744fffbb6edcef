"""The acceleration-level whole-body QP of the pre-impact reshaping (002 Sec. IV, eq. 1).

Decision vector X = (q_ddot, lambda): joint accelerations (Pinocchio coordinates) and friction-
cone coefficients of the current contacts (lambda / 100 for conditioning).

Constraints: floating-base rows of the dynamics, H_b q_ddot + C_b = (J' G)_b lambda; every motor's
torque within its limit; joint accelerations that keep each joint inside its range over a short
horizon.
Cost: sum of weighted set-point tasks |J q_ddot + J_dot q_dot + kp g + kv g_dot|^2 (eq. 1); contact
points neither sinking in nor lifting off within one control step, as a stiff cost (as equalities
they made 12 % of the steps of the shipped sweep fail, mostly once a foot tipped over an edge; as
a cost, 4 %); small
regularisations of lambda and q_ddot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.control.adaptive_gains_qp import LAMBDA_SCALE, QDD_BOUND, ModelTerms
from fallbench.dynamics.contacts import ContactPoint, cone_matrix, normal_matrix
from fallbench.dynamics.dense_qp import ScaledQP
from fallbench.dynamics.model import PinocchioModel

LIMIT_HORIZON_STEPS = 4  # control steps over which joint limits are respected


@dataclass
class SetPoint:
    """One task in the cost: weight |jacobian q_ddot + drift + kp error + kv jacobian v|^2."""

    weight: float
    jacobian: np.ndarray  # (m, nv)
    error: np.ndarray  # (m,)
    drift: np.ndarray  # (m,) J_dot q_dot
    kp: float  # 1/s^2
    kv: float  # 1/s


@dataclass
class ReshapeProblem(ScaledQP):
    n_qdd: int


def joint_acceleration_bounds(q: np.ndarray, qd: np.ndarray, joint_range: np.ndarray, horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """q_ddot bounds that keep q + qd h + q_ddot h^2 / 2 within range (never an empty interval)."""
    low = 2 * (joint_range[:, 0] - q - qd * horizon) / horizon**2
    high = 2 * (joint_range[:, 1] - q - qd * horizon) / horizon**2
    low, high = np.clip(low, -QDD_BOUND, QDD_BOUND), np.clip(high, -QDD_BOUND, QDD_BOUND)
    return np.minimum(low, high), np.maximum(low, high)


def build_reshape_problem(P: PinocchioModel, terms: ModelTerms, points: list[ContactPoint], tasks: list[SetPoint],
                          torque_limit: np.ndarray, joint_range: np.ndarray, dt: float,
                          w_lambda: float, w_qdd: float, w_contact: float) -> ReshapeProblem:
    """torque_limit and joint_range per actuator (MuJoCo order), dt the control period (s)."""
    nv = P.model.nv
    G = cone_matrix(points)
    JtG = terms.contacts.jacobian.T @ G
    n_l = G.shape[1]
    n = nv + n_l
    scale = np.concatenate([np.ones(nv), np.full(n_l, LAMBDA_SCALE)])

    base = np.arange(6)
    A = np.hstack([terms.H[base], -JtG[base]])
    b = -terms.C[base]

    motors = P.actuated_v
    C = np.hstack([terms.H[motors], -JtG[motors]])
    l, u = -torque_limit - terms.C[motors], torque_limit - terms.C[motors]

    H = np.zeros((n, n))
    g = np.zeros(n)
    if points:
        # contacts neither sink in nor lift off: a stiff cost rather than an equality, so that a
        # tipping foot's contact points cannot make the problem infeasible
        normals = normal_matrix(points)
        J_normal = normals @ terms.contacts.jacobian
        offset = normals @ (terms.contacts.velocity / dt + terms.contacts.drift)
        H[:nv, :nv] += w_contact * J_normal.T @ J_normal
        g[:nv] += w_contact * J_normal.T @ offset
    for task in tasks:
        offset = task.drift + task.kp * task.error + task.kv * (task.jacobian @ terms.v)
        H[:nv, :nv] += task.weight * task.jacobian.T @ task.jacobian
        g[:nv] += task.weight * task.jacobian.T @ offset
    H[:nv, :nv] += w_qdd * np.eye(nv)
    H[nv:, nv:] += w_lambda * np.eye(n_l)

    q_joints, v_joints = terms.q[7:][motors - 6], terms.v[motors]
    low, high = joint_acceleration_bounds(q_joints, v_joints, joint_range, LIMIT_HORIZON_STEPS * dt)
    l_box = np.concatenate([np.full(nv, -QDD_BOUND), np.zeros(n_l)])
    u_box = np.concatenate([np.full(nv, QDD_BOUND), np.full(n_l, np.inf)])
    l_box[motors], u_box[motors] = low, high
    return ReshapeProblem(H=scale[:, None] * H * scale[None, :], g=scale * g, A=A * scale, b=b, C=C * scale, l=l, u=u,
                          l_box=l_box / scale, u_box=u_box / scale, scale=scale, n_qdd=nv)
