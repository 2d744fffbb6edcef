"""Reshaping tasks (002 eqs. 3-9): errors, Jacobians and drifts J_dot q_dot against finite differences."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask

EPS = 1e-6
Compute = Callable[[pin.Model, pin.Data], tuple[np.ndarray, np.ndarray, np.ndarray]]


def _kinematics(robot: PinocchioModel, q: np.ndarray, v: np.ndarray) -> None:
    pin.computeJointJacobians(robot.model, robot.data, q)
    pin.forwardKinematics(robot.model, robot.data, q, v, np.zeros(robot.model.nv))
    pin.updateFramePlacements(robot.model, robot.data)


def _check(robot: PinocchioModel, compute: Compute, seed: int) -> None:
    """J v = d(error)/dt and drift = d(J v)/dt along v, by finite differences in q."""
    rng = np.random.default_rng(seed)
    q = pin.randomConfiguration(robot.model, -np.ones(robot.model.nq), np.ones(robot.model.nq))
    v = rng.normal(size=robot.model.nv)
    _kinematics(robot, q, v)
    error, J, drift = compute(robot.model, robot.data)
    q_next = pin.integrate(robot.model, q, v * EPS)
    _kinematics(robot, q_next, v)
    error_next, J_next, _ = compute(robot.model, robot.data)
    np.testing.assert_allclose(J @ v, (error_next - error) / EPS, atol=1e-4 * max(1.0, np.abs(J @ v).max()))
    fd_drift = (J_next @ v - J @ v) / EPS
    np.testing.assert_allclose(drift, fd_drift, atol=2e-3 * max(1.0, np.abs(fd_drift).max()))


def test_vector_orientation(robot: PinocchioModel) -> None:
    task = VectorOrientationTask("torso_2_link", np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    _check(robot, task.compute, 0)
    # error at a known pose: neutral torso's y axis is world y, so g = y - x
    q = pin.neutral(robot.model)
    _kinematics(robot, q, np.zeros(robot.model.nv))
    np.testing.assert_allclose(task.compute(robot.model, robot.data)[0], [-1.0, 1.0, 0.0], atol=1e-9)


def test_relative_distance(robot: PinocchioModel) -> None:
    up, wall = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    task = RelativeDistanceTask(
        SurfacePair(BodyPoint("arm_left_7_link", np.array([0.0, 0.0, -0.05])), np.array([0, 0, 0.3]), up),
        SurfacePair(BodyPoint("arm_right_7_link", np.zeros(3)), np.array([0.8, 0, 0]), wall),
    )
    _check(robot, task.compute, 1)
    q = pin.neutral(robot.model)
    _kinematics(robot, q, np.zeros(robot.model.nv))
    left = robot.data.oMf[robot.model.getFrameId("arm_left_7_link")].act(np.array([0.0, 0.0, -0.05]))
    right = robot.data.oMf[robot.model.getFrameId("arm_right_7_link")].translation
    expected = (left[2] - 0.3) - (right[0] - 0.8)  # eq. 7 by hand
    assert task.compute(robot.model, robot.data)[0][0] == pytest.approx(expected, abs=1e-12)


def test_surface_position(robot: PinocchioModel) -> None:
    tangents = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    task = SurfacePositionTask(BodyPoint("arm_left_7_link", np.zeros(3)), np.array([0.5, 0.2, 0.0]), tangents)
    _check(robot, task.compute, 2)
    q = pin.neutral(robot.model)
    _kinematics(robot, q, np.zeros(robot.model.nv))
    wrist = robot.data.oMf[robot.model.getFrameId("arm_left_7_link")].translation
    np.testing.assert_allclose(
        task.compute(robot.model, robot.data)[0], wrist[:2] - [0.5, 0.2], atol=1e-12
    )  # normal part ignored
