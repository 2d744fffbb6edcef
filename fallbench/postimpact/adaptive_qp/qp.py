"""The adaptive-gain QP of 002 Sec. V (eqs. 10-15), on the shared whole-body layer (`fallbench.dynamics`).

Decision vector y = (lambda, K_S, B_S): friction-cone coefficients of the contact points and PD
stiffness (Nm/rad) and damping (Nms/rad) of the selected motors S; scaled for the solver
(lambda / 100 N; K and B so that K e and B e_dot are ~100 Nm per unit; then Jacobi scaling).
The joint accelerations of X = (q_ddot, lambda, K, B) in 002 are
eliminated through the dynamics (eq. 10 with eq. 15's selected rows):

    q_ddot = H^-1 (J' G lambda + S_S' (e_S K_S + e_dot_S B_S) + S_NS' tau_NS - C),

which satisfies the floating-base rows (no torque there) exactly, so no dynamics row is left.
The non-selected motors keep their last gains (ours, see docs/methods/adaptive_qp.md): their torque is that PD's,
tau_NS = clip(K_NS e + B_NS e_dot, -tau_max, tau_max), known at the solve.

Constraints:
- contact (the authors' `ContactAccConstr`; 002 eq. 11 bounds the contact body's velocity
  instead): zero normal acceleration of every contact point, as independent rows per body;
- torque limits of the selected motors (eq. 12): -tau_max <= e K + e_dot B <= tau_max;
- bounds (eq. 13): lambda >= 0, K >= 0, B >= 0.
Options, off by default: upper bounds K <= k_max, B <= b_max and the over-damping row
B >= ratio K (the authors' code after the paper); B max(|e_dot|, speed) <= tau_max (ours).
Joint limits are not constraints after impact (002); the posture task keeps joints toward q_ref.

Cost (eq. 14): posture and CoM set-point tasks (eq. 1), tangential contact motion (sliding
released, 002 Sec. VII), w_lambda |lambda|^2, w_gains (|K|^2 + |B|^2); optionally (an
extension, off by default) the capture point over the centre of the contact points.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.contacts import ContactSet
from fallbench.dynamics.dense_qp import QPSolver, ScaledQP
from fallbench.dynamics.kernels import compiled
from fallbench.dynamics.limits.contact import ContactLimit, tangential_motion_cost
from fallbench.dynamics.limits.torque import TorqueLimit, TorqueMap
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.objective import AccelerationMap, SetPoint
from fallbench.dynamics.tasks.com import ComTask
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.terms import ModelTerms, model_terms

LAMBDA_SCALE = 100.0  # N per solver unit
TORQUE_UNIT = 100.0  # Nm: K and B are scaled so that one solver unit of K e or B e_dot is about this
ERROR_FLOOR, RATE_FLOOR = 0.01, 0.1  # rad, rad/s: below these the scales stop growing
GRAVITY = 9.81  # m/s^2


@dataclass(frozen=True)
class QPConfig:
    """Weights, task gains and bounds of the adaptive-gain QP (documented in docs/methods/adaptive_qp.md)."""

    w_posture: float = 1.0
    w_com: float = 10.0
    w_tangential: float = 1.0  # soft no-slip of contact points
    w_lambda: float = 1e-6
    w_gains: float = 1e-7
    posture_kp: float = 100.0  # 1/s^2
    posture_kv: float = 20.0  # 1/s
    com_kp: float = 100.0
    com_kv: float = 20.0
    # post-paper options from the authors' later code, off by default (None / 0)
    k_max: float | None = None  # Nm/rad (their code: 2000)
    b_max: float | None = None  # Nms/rad (their code: 2000)
    overdamping_ratio: float = 0.0  # B >= ratio K (their code: 0.1)
    # ours, off by default (0): B max(|e_dot|, speed) <= tau_max, so damping chosen at a near-zero
    # speed cannot ask many times the limit once the joint moves at `speed` (rad/s) between solves
    damping_bound_speed: float = 0.0
    # extension, off by default: capture point over the centre of the contact points
    w_balance: float = 0.0
    balance_rate: float = 10.0  # 1/s, capture-point convergence rate
    ridge: float = 1e-3  # numerical regularisation, relative to the equilibrated Hessian's unit diagonal
    solver: str = "proxsuite"  # or "daqp" (fallbench.dynamics.dense_qp.QP_SOLVERS)
    eps_abs: float = 1e-6  # ProxSuite's absolute tolerance, DAQP's primal tolerance
    # ProxSuite's iteration caps bound its rare very long solves (seen: 62 s uncapped after the
    # fall); a capped solve counts as a failure and the last gains are kept.
    max_iter: int = 200
    max_iter_in: int = 50


@dataclass
class QPProblem(ScaledQP):
    """The assembled adaptive-gain QP in scaled variables, and how to read its solution."""

    n_lambda: int
    selected: np.ndarray  # indices (actuator order) of the selected motors
    acceleration: AccelerationMap  # q_ddot from the physical solution


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


@compiled
def variable_scale(n_lambda: int, e: np.ndarray, e_dot: np.ndarray) -> np.ndarray:
    """Physical per solver unit: lambda in LAMBDA_SCALE, K and B so that their torques K e and B e_dot
    are about TORQUE_UNIT per unit; with fixed scales a gain whose error is near zero is almost free
    and the solver crawls along it (thousands of iterations). e, e_dot of the selected motors."""
    n_s = len(e)
    scale = np.full(n_lambda + 2 * n_s, LAMBDA_SCALE)
    for k in range(n_s):
        scale[n_lambda + k] = TORQUE_UNIT / max(abs(e[k]), ERROR_FLOOR)
        scale[n_lambda + n_s + k] = TORQUE_UNIT / max(abs(e_dot[k]), RATE_FLOOR)
    return scale


def acceleration_map(
    terms: ModelTerms, selected: np.ndarray, e: np.ndarray, e_dot: np.ndarray, held_torque: np.ndarray
) -> AccelerationMap:
    """q_ddot = M (lambda, K_S, B_S) + m from eq. 10 with the non-selected torques known (eq. 15)."""
    assert terms.H_inv is not None, "model_terms(..., inverse=True)"
    state = terms.state
    M, m = _eliminated_accelerations(
        terms.H_inv,
        state.contacts.force_map,
        state.robot.actuated_v,
        selected,
        e,
        e_dot,
        held_torque,
        terms.C,
    )
    return AccelerationMap(M, m)


def torque_map(n_lambda: int, selected: np.ndarray, e: np.ndarray, e_dot: np.ndarray) -> TorqueMap:
    """tau_S = e_S K_S + e_dot_S B_S (the selected motors' PD torques, eq. 12) on y = (lambda, K_S, B_S)."""
    n_s = len(selected)
    matrix = np.zeros((n_s, n_lambda + 2 * n_s))
    diagonal = np.arange(n_s)
    matrix[diagonal, n_lambda + diagonal] = e[selected]
    matrix[diagonal, n_lambda + n_s + diagonal] = e_dot[selected]
    return TorqueMap(matrix, np.zeros(n_s), selected)


@compiled
def _eliminated_accelerations(
    H_inv: np.ndarray,
    force_map: np.ndarray,
    actuated_v: np.ndarray,
    selected: np.ndarray,
    e: np.ndarray,
    e_dot: np.ndarray,
    held_torque: np.ndarray,
    C: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """M = H^-1 [J'G, S_S' diag(e_S), S_S' diag(e_dot_S)], m = H^-1 (S_NS' tau_NS - C)."""
    nv, n_l, n_s = len(C), force_map.shape[1], len(selected)
    M = np.empty((nv, n_l + 2 * n_s))
    if n_l:  # element loops, not slice assignments (see kernels)
        forces = H_inv @ force_map
        for i in range(nv):
            for j in range(n_l):
                M[i, j] = forces[i, j]
    held = np.zeros(nv)  # generalized forces of the non-selected motors' known torques
    for a in range(len(actuated_v)):
        held[actuated_v[a]] = held_torque[a]
    for k in range(n_s):
        motor = actuated_v[selected[k]]
        held[motor] = 0.0  # the selected motors' torques are the QP's
        for i in range(nv):
            M[i, n_l + k] = H_inv[i, motor] * e[selected[k]]
            M[i, n_l + n_s + k] = H_inv[i, motor] * e_dot[selected[k]]
    return M, H_inv @ (held - C)


def _tasks(
    terms: ModelTerms,
    points: ContactSet,
    q_ref: np.ndarray,
    com_ref: np.ndarray,
    dt: float,
    config: QPConfig,
) -> list[SetPoint]:
    state = terms.state
    robot = state.robot
    posture = PostureTask(q_ref, robot.actuated_v, robot.model.nv).compute(state)
    tasks = [
        SetPoint(config.w_posture, posture, config.posture_kp, config.posture_kv),
        SetPoint(config.w_com, ComTask(com_ref).compute(state), config.com_kp, config.com_kv),
        *tangential_motion_cost(state.contacts, config.w_tangential, dt),
    ]
    if config.w_balance > 0 and len(points):
        # capture point xi = c + c_dot / omega driven to the contact centre p at `balance_rate` k:
        # xi_dot = -k (xi - p) <=> c_ddot = -omega k (c - p) - (omega + k) c_dot, a set point on the CoM
        omega = math.sqrt(GRAVITY / max(state.com[2] - float(points.positions[:, 2].min()), 0.1))
        centre = points.positions.mean(axis=0)
        k = config.balance_rate
        horizontal = ComTask(centre).compute(state).select(slice(0, 2))
        tasks.append(SetPoint(config.w_balance, horizontal, omega * k, omega + k))
    return tasks


def build_problem(
    terms: ModelTerms,
    points: ContactSet,
    selected: np.ndarray,
    q_ref: np.ndarray,
    com_ref: np.ndarray,
    e: np.ndarray,
    e_dot: np.ndarray,
    held_torque: np.ndarray,
    torque_limit: np.ndarray,
    dt: float,
    config: QPConfig,
) -> QPProblem:
    """The QP at one state; e, e_dot (rad, rad/s), held_torque (Nm, used for the motors not
    selected) and torque_limit per actuator (MuJoCo order); dt the control period (s)."""
    state = terms.state
    n_l, n_s = state.contacts.force_map.shape[1], len(selected)
    lam, K, B = slice(0, n_l), slice(n_l, n_l + n_s), slice(n_l + n_s, n_l + 2 * n_s)
    scale = variable_scale(n_l, e[selected], e_dot[selected])
    acceleration = acceleration_map(terms, selected, e, e_dot, held_torque)
    qp = QPBuilder(acceleration, scale, state.v, torque_map(n_l, selected, e, e_dot))

    qp.limit(ContactLimit().compute(state))
    qp.limit(TorqueLimit(torque_limit).compute(state))
    if config.overdamping_ratio > 0:
        overdamping = np.zeros((n_s, len(scale)))
        overdamping[:, K], overdamping[:, B] = -config.overdamping_ratio * np.eye(n_s), np.eye(n_s)
        qp.within(overdamping, np.zeros(n_s), np.full(n_s, np.inf))

    e_dot_s, limit_s = e_dot[selected], torque_limit[selected]
    b_upper = np.full(n_s, np.inf if config.b_max is None else config.b_max)
    if config.damping_bound_speed > 0:
        b_upper = np.minimum(b_upper, limit_s / np.maximum(np.abs(e_dot_s), config.damping_bound_speed))
    qp.bound(lam, 0.0, np.inf)
    qp.bound(K, 0.0, np.inf if config.k_max is None else config.k_max)
    qp.bound(B, 0.0, b_upper)

    qp.cost(_tasks(terms, points, q_ref, com_ref, dt, config))
    qp.regularise(lam, config.w_lambda)
    qp.regularise(slice(n_l, n_l + 2 * n_s), config.w_gains)
    problem = qp.build(config.ridge, equilibrate=True)
    return QPProblem(**vars(problem), n_lambda=n_l, selected=selected, acceleration=acceleration)


def solve_step(
    qp: QPSolver,
    robot: PinocchioModel,
    q: np.ndarray,
    v: np.ndarray,
    points: ContactSet,
    selected: np.ndarray,
    q_ref: np.ndarray,
    com_ref: np.ndarray,
    e: np.ndarray,
    e_dot: np.ndarray,
    held_torque: np.ndarray,
    torque_limit: np.ndarray,
    dt: float,
    config: QPConfig,
) -> tuple[QPResult, QPProblem]:
    started = time.perf_counter()
    terms = model_terms(robot, q, v, points)
    modelled = time.perf_counter()
    problem = build_problem(
        terms, points, selected, q_ref, com_ref, e, e_dot, held_torque, torque_limit, dt, config
    )
    built = time.perf_counter()
    status, solved, iterations, y = qp.solve(problem)
    solved_at = time.perf_counter()
    n_l, n_s = problem.n_lambda, len(selected)
    finite = bool(np.isfinite(y).all())  # a failed solve may return no iterate at all
    qdd = (
        problem.acceleration.M @ y + problem.acceleration.m
        if finite
        else np.full(len(problem.acceleration.m), np.nan)
    )
    result = QPResult(
        status,
        solved and finite,
        iterations,
        qdd,
        y[:n_l],
        y[n_l : n_l + n_s],
        y[n_l + n_s :],
        (modelled - started) * 1e3,
        (built - modelled) * 1e3,
        (solved_at - built) * 1e3,
    )
    return result, problem
