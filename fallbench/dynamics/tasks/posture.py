"""Posture task: actuated joints toward reference angles (keeps joints away from their limits)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.task import Task, TaskTerms


@dataclass
class PostureTask(Task):
    target: np.ndarray  # rad, per actuated joint
    joint_v: np.ndarray  # Pinocchio velocity index of each actuated joint
    nv: int
    jacobian: np.ndarray = field(init=False)  # constant: the selection of the joints' velocities
    drift: np.ndarray = field(init=False)  # J_dot q_dot: zero, the Jacobian is constant

    def __post_init__(self) -> None:
        self.jacobian = np.zeros((len(self.joint_v), self.nv))
        self.jacobian[np.arange(len(self.joint_v)), self.joint_v] = 1.0
        self.drift = np.zeros(len(self.joint_v))

    def compute(self, state: RobotState) -> TaskTerms:
        """g = q - q_target (rad); a 1-dof joint's q index is its v index + 1 (the base's quaternion)."""
        q_joints = state.q[7:][self.joint_v - 6]
        return TaskTerms(q_joints - self.target, self.jacobian, self.drift, rows=self.joint_v)
