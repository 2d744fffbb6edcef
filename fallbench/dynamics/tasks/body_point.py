"""Points fixed in a robot body: world positions, Jacobians and drifts (shared by the point tasks)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.state import RobotState

ONE_BODY = np.zeros(1, dtype=np.int64)  # body_of of a single point


@dataclass
class BodyPoint:
    frame: str  # Pinocchio frame of the body
    local: np.ndarray  # m, in the body frame

    def position(self, state: RobotState) -> np.ndarray:
        """m, world."""
        placement = state.frame_placement(state.robot.frame_id(self.frame))
        return placement.translation + placement.rotation @ self.local

    def kinematics(self, state: RobotState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position (m), Jacobian (3, nv), drift J_dot q_dot (m/s^2)) in the world frame."""
        frame = state.robot.frame_id(self.frame)
        placement = state.frame_placement(frame)
        offset = placement.rotation @ self.local
        jacobians, drifts = state.points_kinematics([frame], ONE_BODY, offset[None, :])
        return placement.translation + offset, jacobians[0], drifts[0]
