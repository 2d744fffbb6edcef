"""The one interface of the whole-body QPs' limits: at a measured state, rows of one type.

A limit bounds a quantity x of the robot that every QP can express in its own variables y: the
joint accelerations (q_ddot = M y + m, `objective.AccelerationMap`) or the motor torques
(tau = T y + t, `torque.TorqueMap`); the builder carries the rows into y.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from enum import Enum

import numpy as np

from fallbench.dynamics.state import RobotState


class Space(Enum):
    """The quantity x that a limit's rows bound."""

    ACCELERATION = (
        "q_ddot"  # joint accelerations, Pinocchio velocity coordinates (rad/s^2, m/s^2 for the base)
    )
    TORQUE = "tau"  # motor torques, Nm, actuator (MuJoCo) order


@dataclass(frozen=True)
class LimitRows:
    """lower <= matrix x <= upper, or matrix x = lower when `equality`; matrix None: bounds on x itself."""

    space: Space
    matrix: np.ndarray | None  # (k, len(x))
    lower: np.ndarray  # (k,), x's unit
    upper: np.ndarray  # (k,)
    equality: bool = False

    @classmethod
    def bounds(cls, space: Space, lower: np.ndarray, upper: np.ndarray) -> LimitRows:
        """lower <= x <= upper."""
        return cls(space, None, lower, upper)

    @classmethod
    def equal(cls, space: Space, matrix: np.ndarray, value: np.ndarray) -> LimitRows:
        """matrix x = value."""
        return cls(space, matrix, value, value, equality=True)


class Limit(ABC):
    """A constraint of the whole-body QPs."""

    @abstractmethod
    def compute(self, state: RobotState) -> LimitRows:
        """The limit's rows at `state`."""
