"""One finite-difference check for every task of the whole-body layer: along a random velocity v,
J v is the error's rate and the drift is the rate of J v (J_dot q_dot), at random configurations."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask
from fallbench.dynamics.terms import ModelTerms, model_terms

EPS = 1e-6
Terms = tuple[np.ndarray, np.ndarray, np.ndarray]
UP, WALL = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])


def _posture(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    task = PostureTask(np.zeros(len(robot.actuated_v)), robot.actuated_v, robot.model.nv)
    return task.error(terms.q[7:][robot.actuated_v - 6]), task.jacobian(), task.drift()


def _com(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    return terms.com, terms.J_com, terms.com_drift


def _body_point(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    return BodyPoint("leg_right_6_link", np.array([0.1, -0.05, -0.1])).kinematics(robot.model, robot.data)


def _vector_orientation(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    return VectorOrientationTask("torso_2_link", np.array([0.0, 1.0, 0.0]), WALL).compute(
        robot.model, robot.data
    )


def _surface_position(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    task = SurfacePositionTask(
        BodyPoint("arm_right_7_link", np.array([0.0, 0.0, -0.05])), np.array([0.5, 0.2, 0.0]), np.eye(3)[:2]
    )
    return task.compute(robot.model, robot.data)


def _relative_distance(robot: PinocchioModel, terms: ModelTerms) -> Terms:
    task = RelativeDistanceTask(
        SurfacePair(BodyPoint("arm_left_7_link", np.array([0.0, 0.0, -0.05])), np.array([0, 0, 0.3]), UP),
        SurfacePair(BodyPoint("arm_right_7_link", np.array([0.0, 0.0, -0.05])), np.array([0.8, 0, 0]), -WALL),
    )
    return task.compute(robot.model, robot.data)


TASKS: dict[str, Callable[[PinocchioModel, ModelTerms], Terms]] = {
    "posture": _posture,
    "com": _com,
    "body_point": _body_point,
    "vector_orientation": _vector_orientation,
    "surface_position": _surface_position,
    "relative_distance": _relative_distance,
}


@pytest.mark.parametrize("name", TASKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_task_jacobian_and_drift(robot: PinocchioModel, name: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    v = rng.normal(size=robot.model.nv)
    error, J, drift = (np.copy(a) for a in TASKS[name](robot, model_terms(robot, q, v, [])))
    q_next = pin.integrate(robot.model, q, v * EPS)
    error_next, J_next, _ = TASKS[name](robot, model_terms(robot, q_next, v, []))
    rate = J @ v
    np.testing.assert_allclose(rate, (error_next - error) / EPS, atol=1e-4 * max(1.0, np.abs(rate).max()))
    fd_drift = (J_next @ v - rate) / EPS
    np.testing.assert_allclose(drift, fd_drift, atol=2e-3 * max(1.0, np.abs(fd_drift).max()))
