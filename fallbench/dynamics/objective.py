"""Set-point tasks as a quadratic cost in a QP's own variables (002 eq. 1).

A task with error g, Jacobian J and drift J_dot q_dot costs
weight |J q_ddot + J_dot q_dot + kp g + kv J v|^2. Each QP says how its variables y give the joint
accelerations, q_ddot = M y + m (`AccelerationMap`); the cost is then stacked in y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SetPoint:
    """One task in the cost: weight |jacobian q_ddot + drift + kp error + kv jacobian v|^2."""

    weight: float
    jacobian: np.ndarray | None  # (k, nv); None when `rows` says which velocity entries it picks
    error: np.ndarray  # (k,)
    drift: np.ndarray  # (k,) J_dot q_dot
    kp: float  # 1/s^2
    kv: float  # 1/s
    rows: np.ndarray | None = None  # a selection Jacobian as the velocity indices it picks (faster)


@dataclass
class AccelerationMap:
    """q_ddot = M y + m: the joint accelerations (Pinocchio coordinates) as an affine map of a QP's variables."""

    M: np.ndarray  # (nv, n)
    m: np.ndarray  # (nv,)

    def of(self, task: SetPoint) -> tuple[np.ndarray, np.ndarray]:
        """(J M, J m) for a task."""
        if task.rows is not None:
            return self.M[task.rows], self.m[task.rows]
        assert task.jacobian is not None
        return task.jacobian @ self.M, task.jacobian @ self.m


def add_set_points(H: np.ndarray, g: np.ndarray, tasks: list[SetPoint], acceleration: AccelerationMap, v: np.ndarray) -> None:
    """H += sum w (J M)'(J M), g += sum w (J M)'(J m + drift + kp g + kv J v), in place."""
    for task in tasks:
        velocity = v[task.rows] if task.rows is not None else task.jacobian @ v  # type: ignore[operator]
        JM, Jm = acceleration.of(task)
        offset = Jm + task.drift + task.kp * task.error + task.kv * velocity
        H += task.weight * (JM.T @ JM)
        g += task.weight * (JM.T @ offset)
