"""Joint-range limits as joint-acceleration bounds over a short horizon."""

from __future__ import annotations

import numpy as np
from numba import njit

QDD_BOUND = 1e4  # rad/s^2: bounds beyond this add nothing and would only worsen the conditioning


@njit(cache=True)
def joint_acceleration_bounds(q: np.ndarray, qd: np.ndarray, joint_range: np.ndarray, horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """q_ddot bounds (rad/s^2) that keep q + qd h + q_ddot h^2 / 2 within range (never an empty interval)."""
    low = 2 * (joint_range[:, 0] - q - qd * horizon) / horizon**2
    high = 2 * (joint_range[:, 1] - q - qd * horizon) / horizon**2
    low, high = np.clip(low, -QDD_BOUND, QDD_BOUND), np.clip(high, -QDD_BOUND, QDD_BOUND)
    return np.minimum(low, high), np.maximum(low, high)
