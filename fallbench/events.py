"""Fall and impact detection, as a controller on the robot would see them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def tilt_deg(rotation: np.ndarray) -> float:
    """Angle between a body's z axis and the world vertical, deg."""
    return math.degrees(math.acos(float(np.clip(rotation[2, 2], -1.0, 1.0))))


@dataclass
class FallDetector:
    """A fall starts when the torso tilts past `tilt` deg (000) or the IMU has read free fall for
    `freefall_hold` s. The hold matters at t = 0 of a standing start: the feet touch the floor
    without load yet, so the first reading is free fall although the robot stands."""

    tilt: float  # deg
    freefall: float  # m/s^2, accelerometer norm below which the robot is in free fall
    freefall_hold: float  # s
    time: float | None = None
    reason: str = ""
    freefall_since: float | None = None

    def update(self, t: float, torso_rotation: np.ndarray, imu_acc: np.ndarray) -> bool:
        if self.time is not None:
            return True
        if float(np.linalg.norm(imu_acc)) >= self.freefall:
            self.freefall_since = None
        elif self.freefall_since is None:
            self.freefall_since = t
        if tilt_deg(torso_rotation) > self.tilt:
            self.time, self.reason = t, "tilt"
        elif self.freefall_since is not None and t - self.freefall_since >= self.freefall_hold - 1e-9:
            self.time, self.reason = self.freefall_since, "freefall"
        return self.time is not None


@dataclass
class ImpactDetector:
    """Impact: the first contact, after the fall starts, of a body that was not touching then.

    In a drop nothing touches at the start of the fall, so the feet's first contact is the impact.
    """

    support: set[str] | None = None  # bodies in contact when the fall was detected
    time: float | None = None
    bodies: list[str] = field(default_factory=list)

    def start(self, touching: set[str]) -> None:
        if self.support is None:
            self.support = set(touching)

    def update(self, t: float, touching: set[str]) -> bool:
        if self.time is None and self.support is not None:
            new = sorted(touching - self.support)
            if new:
                self.time, self.bodies = t, new
        return self.time is not None
