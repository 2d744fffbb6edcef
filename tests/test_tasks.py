"""Contact-point Jacobians and drifts against finite differences, friction cones (Pinocchio model of TALOS);
every task is checked in test_task_jacobians."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.contacts import ContactSet, contact_kinematics, friction_generators
from fallbench.dynamics.model import PinocchioModel

EPS = 1e-6


def _state(robot: PinocchioModel, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    q[7:] = np.clip(q[7:], robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:])
    return q, rng.normal(size=robot.model.nv)


def _point(robot: PinocchioModel, q: np.ndarray) -> ContactSet:
    pin.framesForwardKinematics(robot.model, robot.data, q)
    frame = robot.model.getFrameId("leg_right_6_link")
    position = robot.data.oMf[frame].act(np.array([0.1, -0.05, -0.1]))
    normal = np.array([0.0, 0.0, 1.0])
    generators = friction_generators(normal, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 0.7)
    return ContactSet.of_points(["leg_right_6_link"], position, normal, generators)


def _point_position(robot: PinocchioModel, q: np.ndarray, local: np.ndarray) -> np.ndarray:
    pin.framesForwardKinematics(robot.model, robot.data, q)
    return robot.data.oMf[robot.model.getFrameId("leg_right_6_link")].act(local)


def test_contact_point_jacobian_and_drift(robot: PinocchioModel) -> None:
    q, v = _state(robot)
    point = _point(robot, q)
    frame = robot.model.getFrameId("leg_right_6_link")
    local = robot.data.oMf[frame].actInv(point.positions[0])
    pin.computeJointJacobians(robot.model, robot.data, q)
    pin.forwardKinematics(robot.model, robot.data, q, v, np.zeros(robot.model.nv))
    pin.updateFramePlacements(robot.model, robot.data)
    kin = contact_kinematics(robot, v, point)
    # velocity = J v, and J against finite differences of the point position along v
    fd_velocity = (
        _point_position(robot, pin.integrate(robot.model, q, v * EPS), local)
        - _point_position(robot, q, local)
    ) / EPS
    np.testing.assert_allclose(kin.jacobian @ v, fd_velocity, atol=1e-4)
    np.testing.assert_allclose(kin.velocity, kin.jacobian @ v, atol=1e-9)
    # drift = d/dt (J) v: finite difference of J(q + v dt) v
    q_next = pin.integrate(robot.model, q, v * EPS)
    pin.computeJointJacobians(robot.model, robot.data, q_next)
    pin.forwardKinematics(robot.model, robot.data, q_next, v, np.zeros(robot.model.nv))
    pin.updateFramePlacements(robot.model, robot.data)
    moved = ContactSet.of_points(
        point.bodies, robot.data.oMf[frame].act(local), point.normals, point.generators
    )
    fd_drift = (contact_kinematics(robot, v, moved).velocity - kin.velocity) / EPS
    np.testing.assert_allclose(kin.drift, fd_drift, atol=2e-3 * max(1.0, np.abs(fd_drift).max()))


def test_friction_generators_are_unit_and_inside_the_cone() -> None:
    n, t1, t2 = np.eye(3)[2], np.eye(3)[0], np.eye(3)[1]
    G = friction_generators(n, t1, t2, 0.5)
    np.testing.assert_allclose(np.linalg.norm(G, axis=0), 1.0)
    tangential = np.linalg.norm(G[:2], axis=0)
    np.testing.assert_allclose(tangential / G[2], 0.5)  # on the cone's edge: |f_t| = mu f_n


def test_points_of_one_body_match_one_at_a_time(robot: PinocchioModel) -> None:
    q, v = _state(robot, 3)
    first = _point(robot, q)
    second = ContactSet.of_points(
        first.bodies, first.positions + np.array([0.05, 0.02, 0.0]), first.normals, first.generators
    )
    both_points = ContactSet.of_points(
        first.bodies * 2,
        np.vstack([first.positions, second.positions]),
        np.vstack([first.normals, second.normals]),
        np.concatenate([first.generators, second.generators]),
    )
    pin.computeJointJacobians(robot.model, robot.data, q)
    pin.forwardKinematics(robot.model, robot.data, q, v, np.zeros(robot.model.nv))
    pin.updateFramePlacements(robot.model, robot.data)
    both = contact_kinematics(robot, v, both_points)
    alone = contact_kinematics(robot, v, second)
    np.testing.assert_allclose(both.jacobian[3:], alone.jacobian, atol=1e-12)
    np.testing.assert_allclose(both.drift[3:], alone.drift, atol=1e-12)
    assert not np.allclose(both.jacobian[:3], both.jacobian[3:])
