"""Joint-range limits as joint-acceleration bounds over a short horizon."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.kernels import compiled
from fallbench.dynamics.limits.limit import Limit, LimitRows, Space
from fallbench.dynamics.state import RobotState

QDD_BOUND = 1e4  # rad/s^2: bounds beyond this add nothing and would only worsen the conditioning


@dataclass
class JointLimit(Limit):
    joint_range: np.ndarray  # (actuators, 2) rad, per actuator (MuJoCo order)
    horizon: float  # s

    def compute(self, state: RobotState) -> LimitRows:
        """Bounds on q_ddot (rad/s^2, all nv entries) that keep every actuated joint within its range
        over the horizon (`joint_acceleration_bounds`)."""
        lower, upper = joint_acceleration_bounds(
            state.q, state.v, state.robot.actuated_v, self.joint_range, self.horizon
        )
        return LimitRows.bounds(Space.ACCELERATION, lower, upper)


@compiled
def joint_acceleration_bounds(
    q: np.ndarray, v: np.ndarray, actuated_v: np.ndarray, joint_range: np.ndarray, horizon: float
) -> tuple[np.ndarray, np.ndarray]:
    """q_ddot bounds (rad/s^2, all nv velocity entries) from the configuration q and velocity v
    (Pinocchio's): on the actuated joints (velocity indices actuated_v, ranges joint_range in the
    same order) those that keep q + v h + q_ddot h^2 / 2 within range over `horizon` h (s, never an
    empty interval), +-QDD_BOUND elsewhere."""
    low, high = np.full(len(v), -QDD_BOUND), np.full(len(v), QDD_BOUND)
    for k in range(len(actuated_v)):
        i = actuated_v[k]
        position, rate = (
            q[7 + i - 6],
            v[i],
        )  # a 1-dof joint's q index is its v index + 1 (the base's quaternion)
        first = min(
            max(2 * (joint_range[k, 0] - position - rate * horizon) / horizon**2, -QDD_BOUND), QDD_BOUND
        )
        second = min(
            max(2 * (joint_range[k, 1] - position - rate * horizon) / horizon**2, -QDD_BOUND), QDD_BOUND
        )
        low[i], high[i] = min(first, second), max(first, second)
    return low, high
