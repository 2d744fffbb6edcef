"""The acceleration-level whole-body QP of the pre-impact reshaping (002 Sec. IV, eq. 1), on the
shared whole-body layer (`fallbench.dynamics`).

Decision vector y = (q_ddot, lambda): joint accelerations (Pinocchio coordinates) and friction-
cone coefficients of the current contacts (lambda / 100 for conditioning). The accelerations
stay variables here (eliminating them through H^-1 made this QP slower to solve: the motor torques
it would leave as variables are many and the cost becomes dense).

Constraints: floating-base rows of the dynamics, H_b q_ddot + C_b = (J' G)_b lambda; limits from
the shared layer: every motor's torque within its limit (`TorqueLimit`, the torques given by the
motor rows of the dynamics), joint accelerations that keep each joint inside its range less a
margin over a short horizon (`JointLimit`).
Cost: sum of weighted set-point tasks |J q_ddot + J_dot q_dot + kp g + kv g_dot|^2 (eq. 1); contact
points neither sinking in nor lifting off within one control step, as a stiff cost (as equalities
they made 12 % of the steps of the shipped sweep fail, mostly once a foot tipped over an edge; as
a cost, 4 %); small regularisations of lambda and q_ddot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.dense_qp import QPSolver, ScaledQP
from fallbench.dynamics.kernels import compiled
from fallbench.dynamics.limits.contact import normal_motion_cost
from fallbench.dynamics.limits.joint import JointLimit
from fallbench.dynamics.limits.torque import TorqueLimit, TorqueMap
from fallbench.dynamics.objective import AccelerationMap, SetPoint
from fallbench.dynamics.terms import ModelTerms

LAMBDA_SCALE = 100.0
LIMIT_HORIZON_STEPS = 4  # control steps over which joint limits are respected


@dataclass
class ReshapeProblem(ScaledQP):
    n_qdd: int


def build_reshape_problem(
    terms: ModelTerms,
    tasks: list[SetPoint],
    torque_limit: np.ndarray,
    joint_range: np.ndarray,
    dt: float,
    w_lambda: float,
    w_qdd: float,
    w_contact: float,
    joint_margin: float,
    joint_braking: float = 0.0,
) -> ReshapeProblem:
    """torque_limit and joint_range per actuator (MuJoCo order), dt the control period (s), the
    joints kept joint_margin (rad) inside their ranges; with joint_braking > 0 each joint's speed
    toward a range end held to what joint_braking x its motor's torque limit over its own inertia
    (H_kk, rad/s^2) can stop before it."""
    state = terms.state
    nv = state.model.nv
    assert terms.H is not None, "model_terms(..., inertia=True)"
    JtG = state.contacts.force_map
    n_l = JtG.shape[1]
    qdd, lam = slice(0, nv), slice(nv, nv + n_l)
    acceleration = AccelerationMap.first_variables(nv, nv + n_l)
    base_rows, base_values, torque_rows, torque_bias = _dynamics_rows(
        terms.H, JtG, terms.C, state.robot.actuated_v
    )
    torques = TorqueMap(torque_rows, torque_bias, np.arange(len(torque_bias)))
    qp = QPBuilder(acceleration, np.concatenate([np.ones(nv), np.full(n_l, LAMBDA_SCALE)]), state.v, torques)

    qp.equal(base_rows, base_values)
    qp.limit(TorqueLimit(torque_limit).compute(state))
    horizon = LIMIT_HORIZON_STEPS * dt
    braking = (
        joint_braking * torque_limit / np.diag(terms.H)[state.robot.actuated_v]
        if joint_braking
        else np.zeros(0)
    )
    qp.limit(JointLimit(joint_range, horizon, joint_margin, braking=braking).compute(state))
    qp.bound(lam, 0.0, np.inf)

    costs = list(tasks)
    if len(state.contacts):
        # contacts neither sink in nor lift off: a stiff cost rather than an equality, so that a
        # tipping foot's contact points cannot make the problem infeasible
        costs.append(normal_motion_cost(state.contacts, w_contact, dt))
    qp.cost(costs)
    qp.regularise(qdd, w_qdd)
    qp.regularise(lam, w_lambda)
    return ReshapeProblem(**vars(qp.build()), n_qdd=nv)


@compiled
def _dynamics_rows(
    H: np.ndarray, force_map: np.ndarray, C: np.ndarray, motors: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows on y = (q_ddot, lambda) of the dynamics H q_ddot + C - J'G lambda = tau: on the floating
    base tau = 0, (H_b, -(J'G)_b) y = -C_b; on the motors tau_m = (H_m, -(J'G)_m) y + C_m (the torque
    map of the torque limits). Returns (base rows, -C_b, motor rows, C_m)."""
    nv, n_l = force_map.shape
    rows = np.concatenate((np.arange(6), motors))  # the base's velocity indices, then the motors'
    stacked = np.empty((len(rows), nv + n_l))
    bias = np.empty(len(rows))
    for k in range(len(rows)):  # element loops, not slice assignments (see kernels)
        for j in range(nv):
            stacked[k, j] = H[rows[k], j]
        for j in range(n_l):
            stacked[k, nv + j] = -force_map[rows[k], j]
        bias[k] = C[rows[k]]
    return stacked[:6], -bias[:6], stacked[6:], bias[6:]


def solve_reshape(qp: QPSolver, problem: ReshapeProblem) -> tuple[str, bool, np.ndarray | None]:
    """(status, solved, q_ddot (Pinocchio coordinates) or None when not solved)."""
    status, solved, _, x = qp.solve(problem)
    if not solved or not np.isfinite(x).all():
        return status, False, None
    return status, True, x[: problem.n_qdd]
