"""Every limit of the whole-body layer gives rows of the one type (`LimitRows`); at its boundary a
row has no slack left."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.contacts import ContactSet, friction_generators
from fallbench.dynamics.limits.contact import ContactLimit
from fallbench.dynamics.limits.joint import QDD_BOUND, JointLimit, bounded_reference, inner_range, servo_lag
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


def _talos_range(robot: PinocchioModel) -> np.ndarray:
    """The actuated joints' ranges (rad, (actuators, 2)) in actuator order."""
    model = robot.model
    return np.column_stack([model.lowerPositionLimit[7:], model.upperPositionLimit[7:]])[robot.actuated_v - 6]


def _joint_end(
    rows: LimitRows, robot: PinocchioModel, q: np.ndarray, v: np.ndarray, horizon: float
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each actuated joint's position (rad) and speed (rad/s) at the end of the horizon under the
    lowest and the highest acceleration the rows allow."""
    joints, rates = q[robot.actuated_v + 1], v[robot.actuated_v]
    return [
        (joints + rates * horizon + qdd * horizon**2 / 2, rates + qdd * horizon)
        for qdd in (rows.lower[robot.actuated_v], rows.upper[robot.actuated_v])
    ]


def _random_state(robot: PinocchioModel, band: np.ndarray, rng: np.random.Generator) -> tuple:
    """A configuration with every actuated joint inside `band`, at up to 3 rad/s."""
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)
    q[robot.actuated_v + 1] = rng.uniform(band[:, 0], band[:, 1])
    v[robot.actuated_v] = rng.uniform(-3.0, 3.0, len(robot.actuated_v))
    return q, v


def test_a_margin_keeps_every_joint_inside_the_shrunk_range_over_the_horizon(robot: PinocchioModel) -> None:
    """From random states inside [lo + margin, hi - margin], both ends of every acceleration interval
    leave each joint within that band at the end of the horizon (with a servo lag, its rest point
    q + lag q_dot too), and the interval is never empty."""
    joint_range, margin, horizon = _talos_range(robot), 0.05, 0.02
    band, rng = inner_range(joint_range, margin), np.random.default_rng(3)
    lag = rng.uniform(0.0, 0.02, len(joint_range))
    for servo in (np.zeros(0), lag):
        for _ in range(30):
            q, v = _random_state(robot, band, rng)
            rows = JointLimit(joint_range, horizon, margin, servo).compute(RobotState.measure(robot, q, v))
            assert np.all(rows.lower <= rows.upper)
            for position, rate in _joint_end(rows, robot, q, v, horizon):
                rest = position + (rate * servo if len(servo) else 0.0)
                assert np.all(rest >= band[:, 0] - 1e-9) and np.all(rest <= band[:, 1] + 1e-9)


def test_a_joint_inside_the_margin_may_stay_but_not_go_deeper(robot: PinocchioModel) -> None:
    """At rest on hi - margin a joint has no slack upward; at rest halfway into the margin it still
    has none (it is not forced out: the servo reference is, `bounded_reference`), and it may turn
    back; moving deeper at 1 rad/s it must stop within the horizon."""
    joint_range, margin, horizon = _talos_range(robot), 0.05, 0.02
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)
    q[robot.actuated_v + 1] = joint_range.mean(axis=1)
    first, second, third = robot.actuated_v[:3]
    q[first + 1], q[second + 1] = joint_range[0, 1] - margin, joint_range[1, 1] - margin / 2
    q[third + 1], v[third] = joint_range[2, 1] - margin / 2, 1.0
    rows = JointLimit(joint_range, horizon, margin).compute(RobotState.measure(robot, q, v))
    assert rows.upper[first] == 0.0 and rows.upper[second] == 0.0 and rows.lower[second] < 0.0
    np.testing.assert_allclose(rows.upper[third], -2 * 1.0 / horizon)


def test_a_servo_lag_slows_a_joint_heading_for_its_range_end(robot: PinocchioModel) -> None:
    """0.1 rad short of its upper end at 4 rad/s: without lag the joint may keep its speed (it stops
    short of the end), with a 10 ms lag it must brake so that q + lag q_dot is on the end at the
    end of the horizon."""
    joint_range, horizon, lag = _talos_range(robot), 0.02, 0.01
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)
    k = robot.actuated_v[0]
    q[robot.actuated_v + 1] = joint_range.mean(axis=1)
    q[k + 1], v[k] = joint_range[0, 1] - 0.1, 4.0
    state = RobotState.measure(robot, q, v)
    assert JointLimit(joint_range, horizon).compute(state).upper[k] > 0.0
    servo = np.full(len(joint_range), lag)
    upper = JointLimit(joint_range, horizon, 0.0, servo).compute(state).upper[k]
    travel, rate = 4.0 * horizon + upper * horizon**2 / 2, 4.0 + upper * horizon  # from 0.1 short
    assert upper < 0.0
    np.testing.assert_allclose(travel + lag * rate, 0.1)


def test_braking_leaves_a_joint_the_distance_its_motor_needs_to_stop(robot: PinocchioModel) -> None:
    """With a braking deceleration b, the fastest a joint may leave the horizon toward a range end
    is the speed b stops exactly at the end: v_h^2 = 2 b (end - q_h), both ends, from random
    states; without braking, a joint 0.1 rad short at 4 rad/s may keep its speed, with b = 50
    rad/s^2 (stops from 3.2 rad/s) it must slow down; a joint at rest in the middle is not
    bounded by it."""
    joint_range, horizon = _talos_range(robot), 0.02
    rng, braking = np.random.default_rng(5), np.full(len(joint_range), 50.0)
    for _ in range(30):
        q, v = _random_state(robot, joint_range, rng)
        rows = JointLimit(joint_range, horizon, braking=braking).compute(RobotState.measure(robot, q, v))
        assert np.all(rows.lower <= rows.upper)
        (low_q, low_v), (high_q, high_v) = _joint_end(rows, robot, q, v, horizon)
        upward = (high_v > 0) & (rows.upper[robot.actuated_v] < QDD_BOUND)
        room = joint_range[:, 1] - high_q
        stoppable = high_v**2 <= 2 * braking * np.maximum(room, 0.0) + 1e-9
        assert np.all(stoppable | ~upward | (room < 0))  # (room < 0: the range bound held instead)
        assert np.all(
            (low_v >= 0) | (low_v**2 <= 2 * braking * np.maximum(low_q - joint_range[:, 0], 0.0) + 1e-9)
        )
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)
    q[robot.actuated_v + 1] = joint_range.mean(axis=1)
    k = robot.actuated_v[0]
    q[k + 1], v[k] = joint_range[0, 1] - 0.1, 4.0
    state = RobotState.measure(robot, q, v)
    free, braked = (
        JointLimit(joint_range, horizon).compute(state),
        JointLimit(joint_range, horizon, braking=braking).compute(state),
    )
    assert free.upper[k] > 0.0 and braked.upper[k] < 0.0
    position, rate = 0.1 - 4.0 * horizon - braked.upper[k] * horizon**2 / 2, 4.0 + braked.upper[k] * horizon
    np.testing.assert_allclose(rate**2, 2 * 50.0 * position)
    middle = robot.actuated_v[1]
    assert 0.0 < braked.upper[middle] < free.upper[middle] and free.lower[middle] < braked.lower[middle] < 0.0


def test_a_range_narrower_than_two_margins_shrinks_to_its_middle() -> None:
    band = inner_range(np.array([[0.0, 0.06], [-1.0, 1.0]]), 0.05)
    np.testing.assert_allclose(band, [[0.03, 0.03], [-0.95, 0.95]])


def test_a_reference_on_a_range_end_carries_no_velocity_past_it() -> None:
    """Servo references: a position past the band is clipped onto it and its outward velocity
    dropped; a velocity whose lead (lag x qd_ref) would carry the rest point past the band is cut to
    reach it exactly; inward velocities and lag-free joints are left alone."""
    band = np.array([[-1.0, 1.0]] * 4)
    lag = np.array([0.01, 0.01, 0.01, 0.0])
    q_ref, qd_ref = bounded_reference(
        np.array([1.2, 0.95, 0.9, 2.0]), np.array([3.0, 10.0, -5.0, 7.0]), band, lag
    )
    np.testing.assert_allclose(q_ref, [1.0, 0.95, 0.9, 1.0])
    np.testing.assert_allclose(qd_ref, [0.0, 5.0, -5.0, 7.0])
    assert np.all(q_ref[:3] + lag[:3] * qd_ref[:3] <= band[:3, 1] + 1e-12)


def test_the_servo_lag_is_damping_over_stiffness() -> None:
    np.testing.assert_allclose(servo_lag(np.array([1000.0, 0.0]), np.array([10.0, 1.0])), [0.01, 0.0])


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
