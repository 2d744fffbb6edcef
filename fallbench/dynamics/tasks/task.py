"""The one interface of the whole-body QPs' tasks: at a measured state, a task's error g(q), its
Jacobian and its drift, in the same shape whatever the task.

Sign convention: the error is the measured value minus the target, g = x(q) - x_target, in the
task's own unit (m, rad or a unit vector's components). With J = dg/dq (g_dot = J v) and the drift
J_dot v, the error's acceleration is g_ddot = J q_ddot + J_dot v; a QP asks for the set-point
dynamics g_ddot = -kp g - kv g_dot (002 eq. 1), i.e. J q_ddot + J_dot v + kp g + kv J v = 0
(`objective.SetPoint`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.state import RobotState


@dataclass(frozen=True)
class TaskTerms:
    """A task's terms at one state, k rows."""

    error: np.ndarray  # (k,) g = x - x_target, the task's unit
    jacobian: np.ndarray  # (k, nv) dg/dq, Pinocchio velocity coordinates: g_dot = J v
    drift: np.ndarray  # (k,) J_dot v, the task's unit per s^2: g_ddot = J q_ddot + drift
    # When J selects velocity entries (one 1 per row), their (distinct) indices: the cost then
    # reads these rather than multiplying by J's zeros.
    rows: np.ndarray | None = None

    def select(self, rows: slice | np.ndarray) -> TaskTerms:
        """The terms of some of the task's rows (a slice, indices or a boolean mask)."""
        return TaskTerms(
            self.error[rows],
            self.jacobian[rows],
            self.drift[rows],
            None if self.rows is None else self.rows[rows],
        )


class Task(ABC):
    """A set-point task of the whole-body QPs."""

    @abstractmethod
    def compute(self, state: RobotState) -> TaskTerms:
        """The task's error, Jacobian and drift at `state`."""
