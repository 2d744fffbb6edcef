"""Contact points: friction cones, and the kinematics `RobotState.measure` gives them (their
Jacobians and drifts against finite differences are in test_tasks, as a task)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.contacts import ContactSet, friction_generators
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.state import RobotState

FOOT = "leg_right_6_link"


def _foot_point(robot: PinocchioModel, seed: int) -> tuple[np.ndarray, np.ndarray, ContactSet]:
    """(q, v, a contact point under the right foot at q)."""
    pin.seed(seed)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    v = np.random.default_rng(seed).normal(size=robot.model.nv)
    position = (
        RobotState.measure(robot, q, v)
        .frame_placement(robot.frame_id(FOOT))
        .act(np.array([0.1, -0.05, -0.1]))
    )
    normal = np.array([0.0, 0.0, 1.0])
    generators = friction_generators(normal, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 0.7)
    return q, v, ContactSet.of_points([FOOT], position, normal, generators)


def test_friction_generators_are_unit_and_inside_the_cone() -> None:
    n, t1, t2 = np.eye(3)[2], np.eye(3)[0], np.eye(3)[1]
    G = friction_generators(n, t1, t2, 0.5)
    np.testing.assert_allclose(np.linalg.norm(G, axis=0), 1.0)
    tangential = np.linalg.norm(G[:2], axis=0)
    np.testing.assert_allclose(tangential / G[2], 0.5)  # on the cone's edge: |f_t| = mu f_n


def test_contact_velocity_is_the_jacobian_times_v(robot: PinocchioModel) -> None:
    q, v, point = _foot_point(robot, 0)
    contacts = RobotState.measure(robot, q, v, point).contacts
    np.testing.assert_allclose(contacts.velocity, contacts.jacobian @ v, atol=1e-9)
    np.testing.assert_allclose(contacts.normal_jacobian, point.normals @ contacts.jacobian, atol=1e-12)
    np.testing.assert_allclose(contacts.normal_drift, point.normals @ contacts.drift, atol=1e-12)


def test_points_of_one_body_match_one_at_a_time(robot: PinocchioModel) -> None:
    q, v, first = _foot_point(robot, 3)
    second = ContactSet.of_points(
        first.bodies, first.positions + np.array([0.05, 0.02, 0.0]), first.normals, first.generators
    )
    both_points = ContactSet.of_points(
        first.bodies * 2,
        np.vstack([first.positions, second.positions]),
        np.vstack([first.normals, second.normals]),
        np.concatenate([first.generators, second.generators]),
    )
    both = RobotState.measure(robot, q, v, both_points).contacts
    alone = RobotState.measure(robot, q, v, second).contacts
    np.testing.assert_allclose(both.jacobian[3:], alone.jacobian, atol=1e-12)
    np.testing.assert_allclose(both.drift[3:], alone.drift, atol=1e-12)
    assert not np.allclose(both.jacobian[:3], both.jacobian[3:])
