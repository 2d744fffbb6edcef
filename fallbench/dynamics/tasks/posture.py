"""Posture task: actuated joints toward reference angles (keeps joints away from their limits)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PostureTask:
    target: np.ndarray  # rad, per actuated joint
    joint_v: np.ndarray  # Pinocchio velocity index of each actuated joint
    nv: int

    def error(self, q_joints: np.ndarray) -> np.ndarray:
        """g = q - q_target (rad)."""
        return q_joints - self.target

    def jacobian(self) -> np.ndarray:
        J = np.zeros((len(self.joint_v), self.nv))
        J[np.arange(len(self.joint_v)), self.joint_v] = 1.0
        return J

    def drift(self) -> np.ndarray:
        """J_dot q_dot: zero, the Jacobian is constant."""
        return np.zeros(len(self.joint_v))
