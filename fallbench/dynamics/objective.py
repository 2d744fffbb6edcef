"""Set-point tasks as a quadratic cost in a QP's own variables (002 eq. 1).

A task with error g, Jacobian J and drift J_dot q_dot (`tasks.task.TaskTerms`) costs
weight |J q_ddot + J_dot q_dot + kp g + kv J v|^2. The tasks are summed in joint-acceleration space
first, as the metric W = sum w J'J and the vector r = sum w J'(J_dot q_dot + kp g + kv J v), so that
the whole cost is q_ddot' W q_ddot + 2 r' q_ddot + const, whatever the number of tasks. Each QP says how
its variables y give the joint accelerations, q_ddot = M y + m (`AccelerationMap`); the builder then
carries the cost into y once: H = M' W M, g = M'(W m + r) (`kernels.scaled_problem`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics import kernels
from fallbench.dynamics.tasks.task import TaskTerms

NO_JACOBIAN, NO_ROWS = np.zeros((0, 0)), np.zeros(0, dtype=np.int64)  # a task given by the other


@dataclass
class SetPoint:
    """One task in the cost: weight |J q_ddot + drift + kp error + kv J v|^2 with the task's terms."""

    weight: float
    terms: TaskTerms
    kp: float  # 1/s^2
    kv: float  # 1/s


def task_metric(tasks: list[SetPoint], v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(W, r) of the tasks in joint-acceleration space (see the module's docstring)."""
    W, r = np.zeros((len(v), len(v))), np.zeros(len(v))
    for task in tasks:
        terms = task.terms
        # a selection Jacobian goes as the velocity indices it picks (faster)
        jacobian = (
            NO_JACOBIAN if terms.rows is not None else np.ascontiguousarray(terms.jacobian, dtype=float)
        )
        rows = NO_ROWS if terms.rows is None else terms.rows
        kernels.add_task(
            W,
            r,
            jacobian,
            rows,
            float(task.weight),
            np.asarray(terms.drift, dtype=float),
            np.asarray(terms.error, dtype=float),
            float(task.kp),
            float(task.kv),
            v,
        )
    return W, r


@dataclass
class AccelerationMap:
    """q_ddot = M y + m: the joint accelerations (Pinocchio coordinates) as an affine map of a QP's variables.
    `leading`: M = [I 0] and m = 0, the accelerations are y's first nv entries (the cost then needs no product)."""

    M: np.ndarray  # (nv, n)
    m: np.ndarray  # (nv,)
    leading: bool = False

    @classmethod
    def first_variables(cls, nv: int, n: int) -> AccelerationMap:
        """q_ddot = y[:nv]."""
        return cls(np.eye(nv, n), np.zeros(nv), leading=True)
