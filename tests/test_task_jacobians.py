"""One finite-difference check for every task of the whole-body layer: along a random velocity v,
J v is the error's rate and the drift is the rate of J v (J_dot q_dot), at random configurations."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.model import PinocchioModel, build_pinocchio
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask
from fallbench.dynamics.terms import ModelTerms, model_terms
from fallbench.scenario import Scenario
from fallbench.sim.world import build_world

EPS = 1e-6
Terms = tuple[np.ndarray, np.ndarray, np.ndarray]
UP, WALL = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])


def _posture(P: PinocchioModel, terms: ModelTerms) -> Terms:
    task = PostureTask(np.zeros(len(P.actuated_v)), P.actuated_v, P.model.nv)
    return task.error(terms.q[7:][P.actuated_v - 6]), task.jacobian(), task.drift()


def _com(P: PinocchioModel, terms: ModelTerms) -> Terms:
    return terms.com, terms.J_com, terms.com_drift


def _body_point(P: PinocchioModel, terms: ModelTerms) -> Terms:
    return BodyPoint("leg_right_6_link", np.array([0.1, -0.05, -0.1])).kinematics(P.model, P.data)


def _vector_orientation(P: PinocchioModel, terms: ModelTerms) -> Terms:
    return VectorOrientationTask("torso_2_link", np.array([0.0, 1.0, 0.0]), WALL).compute(P.model, P.data)


def _surface_position(P: PinocchioModel, terms: ModelTerms) -> Terms:
    task = SurfacePositionTask(
        BodyPoint("arm_right_7_link", np.array([0.0, 0.0, -0.05])), np.array([0.5, 0.2, 0.0]), np.eye(3)[:2]
    )
    return task.compute(P.model, P.data)


def _relative_distance(P: PinocchioModel, terms: ModelTerms) -> Terms:
    task = RelativeDistanceTask(
        SurfacePair(BodyPoint("arm_left_7_link", np.array([0.0, 0.0, -0.05])), np.array([0, 0, 0.3]), UP),
        SurfacePair(BodyPoint("arm_right_7_link", np.array([0.0, 0.0, -0.05])), np.array([0.8, 0, 0]), -WALL),
    )
    return task.compute(P.model, P.data)


TASKS: dict[str, Callable[[PinocchioModel, ModelTerms], Terms]] = {
    "posture": _posture,
    "com": _com,
    "body_point": _body_point,
    "vector_orientation": _vector_orientation,
    "surface_position": _surface_position,
    "relative_distance": _relative_distance,
}


@pytest.fixture(scope="module")
def P() -> PinocchioModel:
    return build_pinocchio(build_world(Scenario(name="t", duration=1.0)))


@pytest.mark.parametrize("name", TASKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_task_jacobian_and_drift(P: PinocchioModel, name: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = pin.randomConfiguration(P.model, -np.ones(P.model.nq), np.ones(P.model.nq))
    v = rng.normal(size=P.model.nv)
    error, J, drift = (np.copy(a) for a in TASKS[name](P, model_terms(P, q, v, [])))
    q_next = pin.integrate(P.model, q, v * EPS)
    error_next, J_next, _ = TASKS[name](P, model_terms(P, q_next, v, []))
    rate = J @ v
    np.testing.assert_allclose(rate, (error_next - error) / EPS, atol=1e-4 * max(1.0, np.abs(rate).max()))
    fd_drift = (J_next @ v - rate) / EPS
    np.testing.assert_allclose(drift, fd_drift, atol=2e-3 * max(1.0, np.abs(fd_drift).max()))
