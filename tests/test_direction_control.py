"""004's control pieces on TALOS's Pinocchio model: the inertia Jacobian about the CoP against
finite differences with the stance foot held on the ground, and eq. 5 bringing the swing foot to
its target, and the step's swing path ending when the foot is back on the ground."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.state import RobotState
from fallbench.preimpact.direction.inertia import desired_inertia, inertia_about, inertia_jacobian, to_vector
from fallbench.preimpact.direction.stepping import swing_velocity
from fallbench.preimpact.direction.swing import SwingPath
from fallbench.scenario import Scenario
from fallbench.sim.world import World, initial_state


@pytest.fixture(scope="module")
def talos(world: World, robot: PinocchioModel) -> tuple[World, PinocchioModel, np.ndarray]:
    data = initial_state(world, Scenario(name="stand", duration=1.0))
    q, _ = robot.state(data.qpos, data.qvel)
    rng = np.random.default_rng(3)
    q[7:] += rng.uniform(-0.2, 0.2, robot.model.nq - 7)  # away from symmetric poses
    return world, robot, q


def _anchored_inertia(
    model: pin.Model, data: pin.Data, q: np.ndarray, foot: int, placement: pin.SE3, point: np.ndarray
) -> np.ndarray:
    """I_hat about `point` after moving the base so that the foot frame sits at `placement`."""
    pin.framesForwardKinematics(model, data, q)
    base = placement * data.oMf[foot].inverse() * pin.XYZQUATToSE3(q[:7])
    q = q.copy()
    q[:7] = pin.SE3ToXYZQUAT(base)
    return to_vector(inertia_about(model, data, q, np.zeros(model.nv), point)[0])


def test_inertia_jacobian_matches_finite_differences(talos) -> None:
    world, robot, q = talos
    model, data = robot.model, robot.data
    foot = model.getFrameId(world.robot.feet["left"])
    pin.framesForwardKinematics(model, data, q)
    placement = data.oMf[foot].copy()
    point = placement.translation + np.array([0.1, 0.03, -0.1])  # a ground point near the foot
    inertia_about(model, data, q, np.zeros(model.nv), point)
    pin.computeJointJacobians(model, data, q)
    anchored = set(model.supports[model.frames[foot].parentJoint])
    J = inertia_jacobian(model, data, point, anchored)
    eps = 1e-6
    numeric = np.zeros_like(J)
    for k in range(model.nv - 6):
        step = np.zeros(model.nv)
        step[6 + k] = eps
        plus = _anchored_inertia(model, data, pin.integrate(model, q, step), foot, placement, point)
        minus = _anchored_inertia(model, data, pin.integrate(model, q, -step), foot, placement, point)
        numeric[:, k] = (plus - minus) / (2 * eps)
    assert np.abs(numeric).max() > 1.0  # kg m^2/rad: the test sees real changes
    np.testing.assert_allclose(J, numeric, atol=1e-5 * np.abs(numeric).max())


def test_desired_inertia_turns_the_momentum_toward_the_direction() -> None:
    inertia = np.diag([60.0, 55.0, 8.0]) + 2.0
    momentum = np.array([0.0, 30.0, 1.0])  # tipping about +y: falling toward +x
    target = desired_inertia(inertia, momentum, np.pi / 2)  # fall toward +y instead: spin about -x
    omega = np.linalg.solve(target, momentum)
    np.testing.assert_allclose(target, target.T)
    assert omega[0] < 0 and abs(omega[1]) < 1e-9 * abs(omega[0])


def test_eq5_brings_the_swing_foot_to_its_target(talos) -> None:
    world, robot, q = talos
    model, data = robot.model, robot.data
    swing, stance = (model.getFrameId(world.robot.feet[s]) for s in ("right", "left"))
    columns = np.array([model.joints[j].idx_v for j in model.supports[model.frames[swing].parentJoint][2:]])
    q = q.copy()
    pin.framesForwardKinematics(model, data, q)
    target = data.oMf[swing].translation + np.array([0.15, -0.1, 0.05])
    rotation = data.oMf[swing].rotation.copy()
    dt = 0.005
    for _ in range(300):
        state = RobotState.measure(robot, q, np.zeros(model.nv))
        qd = swing_velocity(state, swing, stance, columns, target, rotation, 20.0, 1.0, 1e-3)
        velocity = np.zeros(model.nv)
        velocity[columns] = qd
        q = pin.integrate(model, q, velocity * dt)
    pin.framesForwardKinematics(model, data, q)
    assert np.linalg.norm(data.oMf[swing].translation - target) < 1e-3
    assert np.linalg.norm(pin.log3(rotation @ data.oMf[swing].rotation.T)) < 1e-3


def test_a_step_ends_when_its_foot_touches_down_even_beside_the_target() -> None:
    """004 Sec. VI: a step ends when its foot meets the ground; on a falling robot it meets it a few
    cm beside the target (4.4 cm on 004 Fig. 8's push) and, loaded, cannot be swung there again."""
    path = SwingPath(np.array([0.0, -0.085, 0.11]), np.array([0.47, -0.36]), 0.08, 0.025)
    assert not path.landed(np.array([0.0, -0.085, 0.11]), touching=True)  # not lifted yet: still standing
    np.testing.assert_allclose(
        path.waypoint(np.array([0.0, -0.085, 0.11])), [0.0, -0.085, 0.19]
    )  # straight up first
    np.testing.assert_allclose(path.waypoint(np.array([0.0, -0.085, 0.16])), [0.47, -0.36, 0.19])  # then over
    np.testing.assert_allclose(path.waypoint(np.array([0.46, -0.36, 0.16])), [0.47, -0.36, 0.11])  # then down
    np.testing.assert_allclose(
        path.waypoint(np.array([0.51, -0.377, 0.13])), [0.47, -0.36, 0.11]
    )  # and it stays on its way down
    assert not path.landed(np.array([0.51, -0.377, 0.13]), touching=False)
    assert path.landed(np.array([0.51, -0.377, 0.117]), touching=True)
