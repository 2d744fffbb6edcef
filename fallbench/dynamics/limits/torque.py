"""Motor torque limits, |tau| <= tau_max (002 eq. 12), on whatever variables a QP gives the torques by."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.limits.limit import Limit, LimitRows, Space
from fallbench.dynamics.state import RobotState


@dataclass
class TorqueMap:
    """tau[motors] = matrix y + bias: the torques of some motors as an affine map of a QP's variables y."""

    matrix: np.ndarray  # (k, n), Nm per unit of y
    bias: np.ndarray  # (k,) Nm
    motors: np.ndarray  # (k,) actuator indices (MuJoCo order)


@dataclass
class TorqueLimit(Limit):
    torque_limit: np.ndarray  # Nm, per actuator (MuJoCo order)

    def compute(self, state: RobotState) -> LimitRows:
        """-tau_max <= tau <= tau_max on every motor (the limit does not depend on the state)."""
        return LimitRows.bounds(Space.TORQUE, -self.torque_limit, self.torque_limit)
