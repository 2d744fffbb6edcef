"""Stepping by the foot-to-foot Jacobian (004 Sec. IV-B-1, eq. 5):
theta_dot = J_R^L# (P_dot_R - P_dot_L), here with 6 rows (linear and angular velocity of the
swing foot relative to the stance foot, world axes) over the swing leg's joints, so that the
sole also stays flat. The tipping base comes from the measured base pose (an IMU would give it).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.dynamics.state import RobotState
from fallbench.preimpact.direction.inertia import damped_solve


def foot_to_foot_jacobian(state: RobotState, swing: int, stance: int, columns: np.ndarray) -> np.ndarray:
    """(6, len(columns)): relative twist of the swing foot frame with respect to the stance foot
    frame (Pinocchio frame ids) per joint velocity; `columns` are Pinocchio velocity indices (the base's are 0-5)."""
    relative = state.frame_jacobian(swing) - state.frame_jacobian(stance)
    return relative[:, columns]


def swing_velocity(
    state: RobotState,
    swing: int,
    stance: int,
    columns: np.ndarray,
    target: np.ndarray,
    target_rotation: np.ndarray,
    gain: float,
    max_speed: float,
    damping: float,
) -> np.ndarray:
    """Joint velocities (rad/s, over `columns`) moving the swing foot frame toward `target` (m, world)
    and `target_rotation`, at `gain` (1/s) and at most `max_speed` (m/s), relative to the stance foot."""
    placement = state.frame_placement(swing)
    linear = gain * (target - placement.translation)
    speed = float(np.linalg.norm(linear))
    if speed > max_speed:
        linear *= max_speed / speed
    angular = gain * pin.log3(target_rotation @ placement.rotation.T)
    # P_dot_L = 0: the stance foot is meant to stay where it is. Feeding back its measured velocity
    # instead would close a loop through our own command (a pushing swing leg lifts the stance foot).
    return damped_solve(
        foot_to_foot_jacobian(state, swing, stance, columns), np.concatenate([linear, angular]), damping
    )
