"""Every task of the whole-body layer through the one `Task` interface: at random (q, v), J v is
the error's rate and the drift is the rate of J v (J_dot q_dot), by finite differences; then each
task's error at a known pose (002 eqs. 3-9, 000 Sec. IV-C)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.contacts import ContactSet, friction_generators
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.com import ComTask
from fallbench.dynamics.tasks.point import PointTask
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.task import Task, TaskTerms
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask

EPS = 1e-6
UP, WALL = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
FOOT, LEFT_WRIST, RIGHT_WRIST = "leg_right_6_link", "arm_left_7_link", "arm_right_7_link"


@dataclass
class ContactPoint(Task):
    """A point fixed in a body, measured as a contact point: its world position as the error, and
    the Jacobian and drift that `RobotState.measure` gives contact points (ContactKinematics), so
    that the generic check covers them too."""

    point: BodyPoint

    def compute(self, state: RobotState) -> TaskTerms:
        position = self.point.position(state)
        generators = friction_generators(UP, WALL, np.cross(UP, WALL), 0.7)
        contact = ContactSet.of_points([self.point.frame], position, UP, generators)
        contacts = RobotState.measure(state.robot, state.q, state.v, contact).contacts
        return TaskTerms(position, contacts.jacobian, contacts.drift)


def _posture(robot: PinocchioModel) -> Task:
    return PostureTask(np.zeros(len(robot.actuated_v)), robot.actuated_v, robot.model.nv)


TASKS: dict[str, Callable[[PinocchioModel], Task]] = {
    "posture": _posture,
    "com": lambda robot: ComTask(np.array([0.1, 0.0, 0.8])),
    "point": lambda robot: PointTask(BodyPoint(FOOT, np.array([0.1, -0.05, -0.1])), np.array([0.3, 0, 0])),
    "contact_point": lambda robot: ContactPoint(BodyPoint(FOOT, np.array([0.1, -0.05, -0.1]))),
    "vector_orientation": lambda robot: VectorOrientationTask(
        "torso_2_link", np.array([0.0, 1.0, 0.0]), WALL
    ),
    "surface_position": lambda robot: SurfacePositionTask(
        BodyPoint(RIGHT_WRIST, np.array([0.0, 0.0, -0.05])), np.array([0.5, 0.2, 0.0]), np.eye(3)[:2]
    ),
    "relative_distance": lambda robot: RelativeDistanceTask(
        SurfacePair(BodyPoint(LEFT_WRIST, np.array([0.0, 0.0, -0.05])), np.array([0, 0, 0.3]), UP),
        SurfacePair(BodyPoint(RIGHT_WRIST, np.array([0.0, 0.0, -0.05])), np.array([0.8, 0, 0]), -WALL),
    ),
}


@pytest.mark.parametrize("name", TASKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_jacobian_and_drift_match_finite_differences(robot: PinocchioModel, name: str, seed: int) -> None:
    task = TASKS[name](robot)
    pin.seed(seed)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    v = np.random.default_rng(seed).normal(size=robot.model.nv)
    now = task.compute(RobotState.measure(robot, q, v))
    later = task.compute(RobotState.measure(robot, pin.integrate(robot.model, q, v * EPS), v))
    rate = now.jacobian @ v
    np.testing.assert_allclose(
        rate, (later.error - now.error) / EPS, atol=1e-4 * max(1.0, np.abs(rate).max())
    )
    fd_drift = (later.jacobian @ v - rate) / EPS
    np.testing.assert_allclose(now.drift, fd_drift, atol=2e-3 * max(1.0, np.abs(fd_drift).max()))
    if now.rows is not None:  # the cost reads the rows instead of the Jacobian: the same selection
        np.testing.assert_array_equal(now.jacobian, np.eye(robot.model.nv)[now.rows])


def _at_neutral(robot: PinocchioModel) -> RobotState:
    return RobotState.measure(robot, pin.neutral(robot.model), np.zeros(robot.model.nv))


def test_vector_orientation_error(robot: PinocchioModel) -> None:
    """The neutral torso's y axis is world y, so g = y - x."""
    task = VectorOrientationTask("torso_2_link", np.array([0.0, 1.0, 0.0]), WALL)
    np.testing.assert_allclose(task.compute(_at_neutral(robot)).error, [-1.0, 1.0, 0.0], atol=1e-9)


def test_relative_distance_error_is_eq7(robot: PinocchioModel) -> None:
    task = RelativeDistanceTask(
        SurfacePair(BodyPoint(LEFT_WRIST, np.array([0.0, 0.0, -0.05])), np.array([0, 0, 0.3]), UP),
        SurfacePair(BodyPoint(RIGHT_WRIST, np.zeros(3)), np.array([0.8, 0, 0]), WALL),
    )
    state = _at_neutral(robot)
    left = state.frame_placement(robot.frame_id(LEFT_WRIST)).act(np.array([0.0, 0.0, -0.05]))
    right = state.frame_placement(robot.frame_id(RIGHT_WRIST)).translation
    expected = (left[2] - 0.3) - (right[0] - 0.8)  # eq. 7 by hand
    assert task.compute(state).error[0] == pytest.approx(expected, abs=1e-12)


def test_surface_position_ignores_the_normal(robot: PinocchioModel) -> None:
    task = SurfacePositionTask(BodyPoint(LEFT_WRIST, np.zeros(3)), np.array([0.5, 0.2, 0.0]), np.eye(3)[:2])
    state = _at_neutral(robot)
    wrist = state.frame_placement(robot.frame_id(LEFT_WRIST)).translation
    np.testing.assert_allclose(task.compute(state).error, wrist[:2] - [0.5, 0.2], atol=1e-12)


def test_point_task_on_one_axis(robot: PinocchioModel) -> None:
    """The wrist's height above a target height (the other coordinates of the target are ignored)."""
    task = PointTask(BodyPoint(LEFT_WRIST, np.zeros(3)), np.array([9.0, 9.0, 0.4]), slice(2, 3))
    state = _at_neutral(robot)
    terms = task.compute(state)
    wrist = state.frame_placement(robot.frame_id(LEFT_WRIST)).translation
    np.testing.assert_allclose(terms.error, [wrist[2] - 0.4], atol=1e-12)
    assert terms.jacobian.shape == (1, robot.model.nv) and terms.drift.shape == (1,)


def test_selected_rows_keep_their_terms(robot: PinocchioModel) -> None:
    """A posture split into two groups of joints (the reshaping QP weights the legs apart)."""
    target = np.linspace(-0.5, 0.5, len(robot.actuated_v))
    terms = PostureTask(target, robot.actuated_v, robot.model.nv).compute(_at_neutral(robot))
    legs = np.arange(len(target)) < 12
    for group in (legs, ~legs):
        part = terms.select(group)
        np.testing.assert_array_equal(part.error, -target[group])
        np.testing.assert_array_equal(part.rows, robot.actuated_v[group])
        np.testing.assert_array_equal(part.jacobian, terms.jacobian[group])
