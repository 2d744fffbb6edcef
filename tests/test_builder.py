"""The shared QP builder against the cost and rows written out directly: the task metric, the
cost carried into a QP's variables, the Jacobi scaling, the tangential-motion identity and the
per-body contact rows (hand-made matrices, no robot)."""

from __future__ import annotations

import numpy as np

from fallbench.dynamics.builder import QPBuilder
from fallbench.dynamics.contacts import ContactKinematics
from fallbench.dynamics.kernels import independent_rows
from fallbench.dynamics.limits.contact import tangential_motion_cost
from fallbench.dynamics.limits.limit import LimitRows, Space
from fallbench.dynamics.objective import AccelerationMap, SetPoint, task_metric
from fallbench.dynamics.tasks.task import TaskTerms

NV = 7
RNG = np.random.default_rng(0)


def _tasks() -> list[SetPoint]:
    jacobian = TaskTerms(RNG.normal(size=3), RNG.normal(size=(3, NV)), RNG.normal(size=3))
    rows = np.array([4, 1])
    selection = TaskTerms(RNG.normal(size=2), np.eye(NV)[rows], RNG.normal(size=2), rows=rows)
    return [SetPoint(2.0, jacobian, 100.0, 20.0), SetPoint(0.5, selection, 10.0, 3.0)]


def _direct_cost(
    tasks: list[SetPoint], acceleration: AccelerationMap, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """sum w |J (M y + m) + drift + kp e + kv J v|^2 = y'Hy + 2 g'y + const, task by task."""
    n = acceleration.M.shape[1]
    H, g = np.zeros((n, n)), np.zeros(n)
    for task in tasks:
        terms = task.terms
        J = terms.jacobian if terms.rows is None else np.eye(NV)[terms.rows]
        JM = J @ acceleration.M
        offset = J @ acceleration.m + terms.drift + task.kp * terms.error + task.kv * J @ v
        H += task.weight * JM.T @ JM
        g += task.weight * JM.T @ offset
    return H, g


def test_task_metric_is_the_sum_of_the_tasks() -> None:
    tasks, v = _tasks(), RNG.normal(size=NV)
    W, r = task_metric(tasks, v)
    H, g = _direct_cost(tasks, AccelerationMap(np.eye(NV), np.zeros(NV)), v)
    np.testing.assert_allclose(W, H, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r, g, rtol=1e-12, atol=1e-12)


def test_built_cost_and_rows_in_scaled_variables() -> None:
    """H = M'WM + regularisation in y, then x = y / scale with unit diagonal, plus the ridge."""
    n = 5
    acceleration = AccelerationMap(RNG.normal(size=(NV, n)), RNG.normal(size=NV))
    tasks, v = _tasks(), RNG.normal(size=NV)
    qp = QPBuilder(acceleration, np.full(n, 3.0), v)
    qp.cost(tasks)
    qp.regularise(slice(0, 2), 0.1)
    rows = RNG.normal(size=(2, NV))
    qp.limit(LimitRows.equal(Space.ACCELERATION, rows, -np.array([0.3, -0.2])))  # rows q_ddot + r = 0
    inequality = RNG.normal(size=(1, n))
    qp.within(inequality, np.array([-1.0]), np.array([2.0]))
    acceleration_rows = RNG.normal(size=(1, NV))
    qp.limit(LimitRows(Space.ACCELERATION, acceleration_rows, np.array([-3.0]), np.array([4.0])))
    qp.bound(slice(0, n), -4.0, 5.0)
    problem = qp.build(ridge=1e-3, equilibrate=True)

    H, g = _direct_cost(tasks, acceleration, v)
    H[[0, 1], [0, 1]] += 0.1
    scale = 1.0 / np.sqrt(np.diag(H))
    np.testing.assert_allclose(problem.scale, scale, rtol=1e-12)
    np.testing.assert_allclose(
        problem.H, scale[:, None] * H * scale + 1e-3 * np.eye(n), rtol=1e-10, atol=1e-12
    )
    np.testing.assert_allclose(np.diag(problem.H), 1.0 + 1e-3, rtol=1e-12)
    np.testing.assert_allclose(problem.g, scale * g, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(problem.A, rows @ acceleration.M * scale, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(problem.b, -(np.array([0.3, -0.2]) + rows @ acceleration.m), rtol=1e-12)
    np.testing.assert_allclose(problem.C[:1], inequality * scale, rtol=1e-12)
    np.testing.assert_allclose(problem.C[1:], acceleration_rows @ acceleration.M * scale, rtol=1e-12)
    offset = acceleration_rows @ acceleration.m
    np.testing.assert_allclose(problem.l, [-1.0, -3.0 - offset[0]], rtol=1e-12)
    np.testing.assert_allclose(problem.u, [2.0, 4.0 - offset[0]], rtol=1e-12)
    np.testing.assert_allclose(problem.l_box, -4.0 / scale, rtol=1e-12)
    np.testing.assert_allclose(problem.u_box, 5.0 / scale, rtol=1e-12)


def test_first_variables_need_no_product() -> None:
    nv, n = NV, NV + 3
    tasks, v = _tasks(), RNG.normal(size=NV)
    qp = QPBuilder(AccelerationMap.first_variables(nv, n), np.ones(n), v)
    qp.cost(tasks)
    problem = qp.build()
    H, g = _direct_cost(tasks, AccelerationMap(np.eye(nv, n), np.zeros(nv)), v)
    np.testing.assert_allclose(problem.H, H, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(problem.g, g, rtol=1e-12, atol=1e-12)


def _kinematics(points: int) -> ContactKinematics:
    jacobian = RNG.normal(size=(3 * points, NV))
    normals = RNG.normal(size=(points, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    drift = RNG.normal(size=3 * points)
    normal_jacobian = np.einsum("id,idj->ij", normals, jacobian.reshape(points, 3, NV))
    normal_drift = np.einsum("id,id->i", normals, drift.reshape(points, 3))
    return ContactKinematics(
        jacobian,
        drift,
        jacobian @ np.ones(NV),
        normals,
        np.zeros(points, dtype=int),
        normal_jacobian,
        normal_drift,
        np.zeros((NV, 4 * points)),
    )


def test_tangential_cost_is_the_projected_point_motion() -> None:
    """|x|^2 - (n'x)^2 with x = J q_ddot + drift + v / dt equals |(I - n n') x|^2 for every q_ddot."""
    kinematics, v, dt = _kinematics(3), np.ones(NV), 0.005
    W, r = task_metric(tangential_motion_cost(kinematics, 1.5, dt), v)
    projectors = np.eye(3) - np.einsum("id,ie->ide", kinematics.normals, kinematics.normals)
    T = np.zeros((9, 9))
    for i in range(3):
        T[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = projectors[i]
    J, offset = T @ kinematics.jacobian, T @ (kinematics.drift + kinematics.velocity / dt)
    np.testing.assert_allclose(W, 1.5 * J.T @ J, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(r, 1.5 * J.T @ offset, rtol=1e-10, atol=1e-10)


def test_contact_rows_span_each_bodys_rows_and_are_independent() -> None:
    """Four coplanar corner rows of rank 3 on body 0 and one row on body 1 -> 3 + 1 rows, same span."""
    base = RNG.normal(size=(3, NV + 1))
    foot = np.vstack([base, base[0] + base[1] - base[2]])  # the fourth row depends on the others
    rows = np.vstack([foot, RNG.normal(size=(1, NV + 1))])
    combined = independent_rows(rows[:, :NV], rows[:, NV], np.array([0, 0, 0, 0, 1]), 1e-6)
    assert combined.shape == (4, NV + 1)
    assert np.linalg.matrix_rank(combined[:, :NV]) == 4
    # every original row is a combination of the kept ones (both sets have rank 4: the same span)
    _, residual, _, _ = np.linalg.lstsq(combined.T, rows.T, rcond=None)
    np.testing.assert_allclose(residual, 0.0, atol=1e-18)
