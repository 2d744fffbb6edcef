"""The acceleration-level whole-body QP of the pre-impact reshaping (002 Sec. IV, eq. 1), on the
shared whole-body layer (`fallbench.dynamics`).

Decision vector y = (q_ddot, lambda): joint accelerations (Pinocchio coordinates) and friction-
cone coefficients of the current contacts (lambda / 100 for conditioning). The accelerations
stay variables here (eliminating them through H^-1 made this QP slower to solve: the motor torques
it would leave as variables are many and the cost becomes dense).

Constraints: floating-base rows of the dynamics, H_b q_ddot + C_b = (J' G)_b lambda; every motor's
torque within its limit; joint accelerations that keep each joint inside its range over a short
horizon.
Cost: sum of weighted set-point tasks |J q_ddot + J_dot q_dot + kp g + kv g_dot|^2 (eq. 1); contact
points neither sinking in nor lifting off within one control step, as a stiff cost (as equalities
they made 12 % of the steps of the shipped sweep fail, mostly once a foot tipped over an edge; as
a cost, 4 %); small regularisations of lambda and q_ddot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.contacts import ContactSet
from fallbench.dynamics.dense_qp import QPSolver, ScaledQP
from fallbench.dynamics.limits.contact import normal_motion_cost
from fallbench.dynamics.limits.joint import QDD_BOUND, joint_acceleration_bounds
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.objective import AccelerationMap, SetPoint
from fallbench.dynamics.terms import ModelTerms

LAMBDA_SCALE = 100.0
LIMIT_HORIZON_STEPS = 4  # control steps over which joint limits are respected


@dataclass
class ReshapeProblem(ScaledQP):
    n_qdd: int


def build_reshape_problem(P: PinocchioModel, terms: ModelTerms, points: ContactSet, tasks: list[SetPoint],
                          torque_limit: np.ndarray, joint_range: np.ndarray, dt: float,
                          w_lambda: float, w_qdd: float, w_contact: float) -> ReshapeProblem:
    """torque_limit and joint_range per actuator (MuJoCo order), dt the control period (s)."""
    nv = P.model.nv
    assert terms.H is not None, "model_terms(..., inertia=True)"
    JtG = terms.contacts.force_map
    n_l = JtG.shape[1]
    qdd, lam = slice(0, nv), slice(nv, nv + n_l)
    acceleration = AccelerationMap.first_variables(nv, nv + n_l)
    qp = QPBuilder(acceleration, np.concatenate([np.ones(nv), np.full(n_l, LAMBDA_SCALE)]), terms.v)

    base, motors = np.arange(6), P.actuated_v
    qp.equal(np.hstack([terms.H[base], -JtG[base]]), -terms.C[base])  # H_b qdd + C_b - (J'G)_b lambda = 0
    qp.within(np.hstack([terms.H[motors], -JtG[motors]]), -torque_limit - terms.C[motors], torque_limit - terms.C[motors])
    q_joints, v_joints = terms.q[7:][motors - 6], terms.v[motors]
    low, high = joint_acceleration_bounds(q_joints, v_joints, joint_range, LIMIT_HORIZON_STEPS * dt)
    qdd_low, qdd_high = np.full(nv, -QDD_BOUND), np.full(nv, QDD_BOUND)
    qdd_low[motors], qdd_high[motors] = low, high
    qp.bound(qdd, qdd_low, qdd_high)
    qp.bound(lam, 0.0, np.inf)

    costs = list(tasks)
    if len(points):
        # contacts neither sink in nor lift off: a stiff cost rather than an equality, so that a
        # tipping foot's contact points cannot make the problem infeasible
        costs.append(normal_motion_cost(terms.contacts, w_contact, dt))
    qp.cost(costs)
    qp.regularise(qdd, w_qdd)
    qp.regularise(lam, w_lambda)
    return ReshapeProblem(**vars(qp.build()), n_qdd=nv)


def solve_reshape(qp: QPSolver, problem: ReshapeProblem) -> tuple[str, bool, np.ndarray | None]:
    """(status, solved, q_ddot (Pinocchio coordinates) or None when not solved)."""
    status, solved, _, x = qp.solve(problem)
    if not solved or not np.isfinite(x).all():
        return status, False, None
    return status, True, x[: problem.n_qdd]
