"""Vector-orientation task (002 eqs. 3-5): a unit vector fixed in a body toward a world direction.

The reshaping controller uses it to turn the torso's lateral axis perpendicular to the fall
direction, so that the robot meets the ground front or back rather than sideways.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.task import Task, TaskTerms
from fallbench.dynamics.vectors import cross


@dataclass
class VectorOrientationTask(Task):
    frame: str  # Pinocchio frame of the body
    body_vector: np.ndarray  # unit, body coordinates
    target: np.ndarray  # unit, world

    def compute(self, state: RobotState) -> TaskTerms:
        """Error g = u - u_target (unitless), Jacobian dg/dq (1/rad), drift J_dot q_dot (1/s^2).

        With u = R u_b: u_dot = omega x u, so J = -[u]x J_angular (world-aligned), and
        J_dot q_dot = a_drift x u + omega x (omega x u), a_drift the angular acceleration at q_ddot = 0.
        """
        frame = state.robot.frame_id(self.frame)
        u = state.frame_placement(frame).rotation @ self.body_vector
        J_angular = state.frame_jacobian(frame)[3:]
        omega = state.frame_velocity(frame).angular
        alpha = state.frame_drift(frame).angular
        jacobian = -pin.skew(u) @ J_angular
        drift = cross(alpha, u) + cross(omega, cross(omega, u))
        return TaskTerms(u - self.target, jacobian, drift)
