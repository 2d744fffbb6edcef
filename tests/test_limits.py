"""Every limit of the whole-body layer gives rows of the one type (`LimitRows`); at its boundary a
row has no slack left."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.contacts import ContactSet, friction_generators
from fallbench.dynamics.limits.contact import ContactLimit
from fallbench.dynamics.limits.joint import QDD_BOUND, JointLimit
from fallbench.dynamics.limits.limit import LimitRows, Space
from fallbench.dynamics.limits.torque import TorqueLimit, TorqueMap
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.objective import AccelerationMap
from fallbench.dynamics.state import RobotState

FOOT = "leg_left_6_link"


def _slack(rows: LimitRows, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(matrix x - lower, upper - matrix x): both >= 0 inside the limit."""
    value = x if rows.matrix is None else rows.matrix @ x
    return value - rows.lower, rows.upper - value


def test_a_joint_at_its_range_end_can_only_turn_back(robot: PinocchioModel) -> None:
    """At rest on its upper end a joint may not accelerate further (zero slack at q_ddot = 0); on
    its lower end likewise; the unactuated base is left free."""
    joint_range = np.column_stack([robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]])[
        robot.actuated_v - 6
    ]
    q = pin.neutral(robot.model)
    q[robot.actuated_v[0] + 1], q[robot.actuated_v[1] + 1] = joint_range[0, 1], joint_range[1, 0]
    rows = JointLimit(joint_range, 0.02).compute(RobotState.measure(robot, q, np.zeros(robot.model.nv)))
    assert rows.space is Space.ACCELERATION and rows.matrix is None and not rows.equality
    below, above = _slack(rows, np.zeros(robot.model.nv))
    assert above[robot.actuated_v[0]] == 0.0 and below[robot.actuated_v[1]] == 0.0
    assert np.all(below >= 0.0) and np.all(above >= 0.0)
    np.testing.assert_array_equal(rows.upper[:6], QDD_BOUND)


def test_a_resting_flat_foot_gives_three_contact_rows(robot: PinocchioModel) -> None:
    """Four sole corners of one foot: three independent equality rows; an acceleration satisfying
    them leaves every corner's normal acceleration at zero."""
    q = pin.neutral(robot.model)
    v = np.random.default_rng(0).normal(size=robot.model.nv)
    sole = RobotState.measure(robot, q, v).frame_placement(robot.frame_id(FOOT))
    corners = [sole.act(np.array([x, y, -0.1])) for x in (-0.1, 0.1) for y in (-0.05, 0.05)]
    normal = sole.rotation[:, 2]
    generators = friction_generators(normal, sole.rotation[:, 0], sole.rotation[:, 1], 0.7)
    points = ContactSet.of_points(
        [FOOT] * 4, np.array(corners), np.tile(normal, (4, 1)), np.tile(generators, (4, 1, 1))
    )
    state = RobotState.measure(robot, q, v, points)
    rows = ContactLimit().compute(state)
    assert rows.space is Space.ACCELERATION and rows.equality and rows.matrix.shape == (3, robot.model.nv)
    qdd = np.linalg.lstsq(rows.matrix, rows.lower, rcond=None)[0]
    np.testing.assert_allclose(_slack(rows, qdd), 0.0, atol=1e-9)
    normal_acceleration = state.contacts.normal_jacobian @ qdd + state.contacts.normal_drift
    np.testing.assert_allclose(normal_acceleration, 0.0, atol=1e-9)


def test_torque_limits_reach_any_qps_variables_through_its_torque_map(robot: PinocchioModel) -> None:
    """The same torque rows on a QP whose torques are tau[motors] = T y + t: at a y whose first
    motor torque is at its limit, that row of the built problem has no slack."""
    limit = np.array([100.0, 50.0, 30.0])
    rows = TorqueLimit(limit).compute(
        RobotState.measure(robot, pin.neutral(robot.model), np.zeros(robot.model.nv))
    )
    assert rows.space is Space.TORQUE and rows.matrix is None
    rng = np.random.default_rng(1)
    torques = TorqueMap(rng.normal(size=(2, 4)), rng.normal(size=2), np.array([0, 2]))
    qp = QPBuilder(AccelerationMap(np.zeros((1, 4)), np.zeros(1)), np.ones(4), np.zeros(1), torques)
    qp.limit(rows)
    problem = qp.build()
    y = np.linalg.lstsq(torques.matrix, np.array([100.0, 0.0]) - torques.bias, rcond=None)[0]
    np.testing.assert_allclose(problem.u - problem.C @ y, [0.0, 30.0], atol=1e-9)
    np.testing.assert_allclose(problem.l, -limit[[0, 2]] - torques.bias)
