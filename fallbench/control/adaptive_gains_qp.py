"""The adaptive-gain QP of 002 Sec. V (eqs. 10-15), solved with ProxSuite.

Decision vector X = (q_ddot, lambda, K_S, B_S): joint accelerations (Pinocchio coordinates),
friction-cone coefficients, and PD stiffness and damping of the selected motors S (those on
the kinematic chains from the contact bodies to the root, eq. 15). Variables are scaled to
similar magnitudes (lambda / 100, K / 1000, B / 10) for the solver's conditioning.

Constraints:
- floating-base rows of the dynamics (eq. 10): H_b qdd + C_b - (J' G)_b lambda = 0;
- selected motor rows: H_S qdd + C_S - (J' G)_S lambda = e_S K_S + e_dot_S B_S;
- non-selected motors: -tau_max <= H_NS qdd + C_NS - (J' G)_NS lambda <= tau_max;
- torque limits of the selected motors (eq. 12): -tau_max <= e K + e_dot B <= tau_max;
- contact points (eq. 11) along their normal: n' (J qdd + J_dot q_dot) = -n' v / dt
  (the tangential part is a cost: sliding contacts are released, as 002 Sec. VII does);
- bounds (eq. 13): lambda >= 0, 0 <= K <= K_max, 0 <= B <= B_max.
Joint limits are not constraints after impact (002); the posture task keeps joints away.

Cost (eq. 14): posture and CoM set-point tasks (eq. 1), w_lambda |lambda|^2, w_G (|K|^2 + |B|^2).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics.dense_qp import DenseQP, ScaledQP
from fallbench.dynamics.contacts import ContactKinematics, ContactPoint, cone_matrix, contact_kinematics, normal_matrix
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.tasks.com import ComTask
from fallbench.dynamics.tasks.posture import PostureTask

LAMBDA_SCALE, K_SCALE, B_SCALE = 100.0, 1000.0, 10.0
QDD_BOUND = 1e4  # rad/s^2 or m/s^2: no real bound, keeps the box finite


@dataclass(frozen=True)
class QPConfig:
    """Weights, task gains and bounds of the adaptive-gain QP (documented in the README)."""

    w_posture: float = 1.0
    w_com: float = 10.0
    w_tangential: float = 1.0  # soft no-slip of contact points
    w_lambda: float = 1e-6
    w_gains: float = 1e-7
    posture_kp: float = 100.0  # 1/s^2
    posture_kv: float = 20.0  # 1/s
    com_kp: float = 100.0
    com_kv: float = 20.0
    k_max: float = 2000.0  # Nm/rad (the authors' bound)
    b_max: float = 2000.0  # Nms/rad
    eps_abs: float = 1e-6
    max_iter: int = 2000


@dataclass
class QPProblem(ScaledQP):
    """The assembled adaptive-gain QP in scaled variables."""

    n_qdd: int
    n_lambda: int
    selected: np.ndarray  # indices (actuator order) of the selected motors


@dataclass
class QPResult:
    status: str
    solved: bool
    iterations: int
    qdd: np.ndarray
    lam: np.ndarray
    K: np.ndarray  # Nm/rad, selected motors
    B: np.ndarray  # Nms/rad
    model_ms: float
    build_ms: float
    solve_ms: float


def select_motors(P: PinocchioModel, bodies: set[str], joint_names: tuple[str, ...]) -> np.ndarray:
    """Actuators on the chains between the contact bodies and the root (002 eq. 15)."""
    chain: set[int] = set()
    for body in bodies:
        joint = P.model.frames[P.model.getFrameId(body)].parentJoint
        chain.update(j for j in P.model.supports[joint] if j > 1)
    names = {P.model.names[j] for j in chain}
    return np.array([i for i, name in enumerate(joint_names) if name in names], dtype=int)


@dataclass
class ModelTerms:
    """Rigid-body terms at one state, Pinocchio coordinates."""

    q: np.ndarray
    v: np.ndarray
    H: np.ndarray  # inertia matrix (with rotor armature)
    C: np.ndarray  # gravity, Coriolis and centrifugal terms
    contacts: ContactKinematics
    com: np.ndarray
    vcom: np.ndarray
    com_drift: np.ndarray
    J_com: np.ndarray


def model_terms(P: PinocchioModel, q: np.ndarray, v: np.ndarray, points: list[ContactPoint]) -> ModelTerms:
    model, data = P.model, P.data
    H = pin.crba(model, data, q)
    H = np.triu(H) + np.triu(H, 1).T
    C = pin.nonLinearEffects(model, data, q, v)
    pin.computeJointJacobians(model, data, q)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    contacts = contact_kinematics(P, v, points)
    com, vcom, com_drift = ComTask.state(model, data, q, v)
    return ModelTerms(q, v, H, C, contacts, com, vcom, com_drift, ComTask.jacobian(model, data, q))


def build_problem(P: PinocchioModel, terms: ModelTerms, points: list[ContactPoint],
                  q_ref: np.ndarray, com_ref: np.ndarray, e: np.ndarray, e_dot: np.ndarray,
                  torque_limit: np.ndarray, joint_names: tuple[str, ...], dt: float, cfg: QPConfig) -> QPProblem:
    """Assemble the QP from the model terms; e, e_dot, torque_limit per actuator (MuJoCo order)."""
    nv = P.model.nv
    q, v, H_dyn, C_dyn, kin = terms.q, terms.v, terms.H, terms.C, terms.contacts
    G = cone_matrix(points)
    JtG = kin.jacobian.T @ G  # (nv, n_lambda)

    selected = select_motors(P, {p.body for p in points}, joint_names)
    not_selected = np.setdiff1d(np.arange(len(joint_names)), selected)
    sel_v, ns_v = P.actuated_v[selected], P.actuated_v[not_selected]
    n_l, n_s = G.shape[1], len(selected)
    n = nv + n_l + 2 * n_s
    scale = np.concatenate([np.ones(nv), np.full(n_l, LAMBDA_SCALE), np.full(n_s, K_SCALE), np.full(n_s, B_SCALE)])

    # Equalities, in physical variables first: [H, -J'G, -diag(e), -diag(e_dot)] X = -C.
    def dynamics_rows(rows: np.ndarray, with_gains: bool) -> np.ndarray:
        block = np.zeros((len(rows), n))
        block[:, :nv] = H_dyn[rows]
        block[:, nv : nv + n_l] = -JtG[rows]
        if with_gains:
            block[np.arange(n_s), nv + n_l + np.arange(n_s)] = -e[selected]
            block[np.arange(n_s), nv + n_l + n_s + np.arange(n_s)] = -e_dot[selected]
        return block

    base = np.arange(6)
    normals = normal_matrix(points)
    contact_rows = np.zeros((len(points), n))
    contact_rows[:, :nv] = normals @ kin.jacobian
    A = np.vstack([dynamics_rows(base, False), dynamics_rows(sel_v, True), contact_rows])
    b = np.concatenate([-C_dyn[base], -C_dyn[sel_v], normals @ (-kin.velocity / dt - kin.drift)])

    # Inequalities: non-selected motor torques, selected motor torques (eq. 12).
    ns_rows = dynamics_rows(ns_v, False)  # tau - C = H qdd - J'G lambda
    gain_rows = np.zeros((n_s, n))
    gain_rows[np.arange(n_s), nv + n_l + np.arange(n_s)] = e[selected]
    gain_rows[np.arange(n_s), nv + n_l + n_s + np.arange(n_s)] = e_dot[selected]
    C = np.vstack([ns_rows, gain_rows])
    limit_ns, limit_s = torque_limit[not_selected], torque_limit[selected]
    l = np.concatenate([-limit_ns - C_dyn[ns_v], -limit_s])
    u = np.concatenate([limit_ns - C_dyn[ns_v], limit_s])

    # Cost: sum_k w_k |J_k qdd + J_dot_k v + kp g + kv g_dot|^2 + regularisation.
    posture = PostureTask(q_ref, P.actuated_v, nv)
    q_joints = q[7:][P.actuated_v - 6]
    v_joints = v[P.actuated_v]
    com_task = ComTask(com_ref)
    tasks = [
        (cfg.w_posture, posture.jacobian(), posture.drift() + cfg.posture_kp * posture.error(q_joints) + cfg.posture_kv * v_joints),
        (cfg.w_com, terms.J_com, terms.com_drift + cfg.com_kp * com_task.error(terms.com) + cfg.com_kv * terms.vcom),
    ]
    if points:
        tangential = kin.jacobian - normals.T @ (normals @ kin.jacobian)
        tangential_target = kin.drift - normals.T @ (normals @ kin.drift) + (kin.velocity - normals.T @ (normals @ kin.velocity)) / dt
        tasks.append((cfg.w_tangential, tangential, tangential_target))
    H = np.zeros((n, n))
    g = np.zeros(n)
    for weight, J, offset in tasks:
        H[:nv, :nv] += weight * J.T @ J
        g[:nv] += weight * J.T @ offset
    H[nv : nv + n_l, nv : nv + n_l] += cfg.w_lambda * np.eye(n_l)
    H[nv + n_l :, nv + n_l :] += cfg.w_gains * np.eye(2 * n_s)
    H[:nv, :nv] += 1e-9 * np.eye(nv)  # strictly convex

    l_box = np.concatenate([np.full(nv, -QDD_BOUND), np.zeros(n_l + 2 * n_s)])
    u_box = np.concatenate([np.full(nv, QDD_BOUND), np.full(n_l, np.inf), np.full(n_s, cfg.k_max), np.full(n_s, cfg.b_max)])
    # Scale: X = S x, so H -> S H S, g -> S g, A -> A S, C -> C S, box / S.
    return QPProblem(H=scale[:, None] * H * scale[None, :], g=scale * g, A=A * scale, b=b, C=C * scale, l=l, u=u,
                     l_box=l_box / scale, u_box=u_box / scale, scale=scale, n_qdd=nv, n_lambda=n_l, selected=selected)


def solve_step(qp: DenseQP, P: PinocchioModel, q: np.ndarray, v: np.ndarray, points: list[ContactPoint],
               q_ref: np.ndarray, com_ref: np.ndarray, e: np.ndarray, e_dot: np.ndarray, torque_limit: np.ndarray,
               joint_names: tuple[str, ...], dt: float, cfg: QPConfig) -> tuple[QPResult, QPProblem]:
    started = time.perf_counter()
    terms = model_terms(P, q, v, points)
    modelled = time.perf_counter()
    problem = build_problem(P, terms, points, q_ref, com_ref, e, e_dot, torque_limit, joint_names, dt, cfg)
    built = time.perf_counter()
    status, solved, iterations, x = qp.solve(problem)
    solved_at = time.perf_counter()
    nv, n_l, n_s = problem.n_qdd, problem.n_lambda, len(problem.selected)
    result = QPResult(status, solved and bool(np.isfinite(x).all()), iterations, x[:nv], x[nv : nv + n_l],
                      x[nv + n_l : nv + n_l + n_s], x[nv + n_l + n_s :],
                      (modelled - started) * 1e3, (built - modelled) * 1e3, (solved_at - built) * 1e3)
    return result, problem
