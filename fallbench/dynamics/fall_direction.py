"""Fall direction (002 eq. 2) and the fall's class relative to the torso (000 Sec. IV-A)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.vectors import UP, cross

MIN_TRAVEL = 1e-3  # m of CoM travel below which eq. 2 is undefined; the torso's lean stands in


def horizontal_unit(vector: np.ndarray) -> np.ndarray | None:
    """The ground-plane part of a 3D vector, normalised; None when it is (almost) vertical."""
    flat = np.array([vector[0], vector[1], 0.0])
    norm = float(np.linalg.norm(flat))
    return flat / norm if norm > 1e-9 else None


@dataclass
class FallDirection:
    """d_f = (p_c(t) - p_c(t_d)) / |...|: ground projection of the CoM since the fall was detected."""

    com_at_detection: np.ndarray  # m, world

    def update(self, com: np.ndarray, torso_z_axis: np.ndarray) -> np.ndarray:
        travel = horizontal_unit(com - self.com_at_detection)
        if travel is not None and np.linalg.norm((com - self.com_at_detection)[:2]) >= MIN_TRAVEL:
            return travel
        lean = horizontal_unit(torso_z_axis)
        return lean if lean is not None else np.array([1.0, 0.0, 0.0])


def heading(torso_rotation: np.ndarray) -> np.ndarray:
    """The torso's forward direction in the ground plane, from its lateral (y) axis so that it
    stays defined when the torso pitches past horizontal in a front or back fall."""
    forward = horizontal_unit(cross(torso_rotation[:, 1], UP))
    return forward if forward is not None else np.array([1.0, 0.0, 0.0])


def fall_class(direction: np.ndarray, torso_rotation: np.ndarray) -> str:
    """`front`, `back`, `left` or `right`: the fall direction against the torso's heading
    (front within 45 deg of forward, back within 45 deg of backward, else a side fall)."""
    forward = heading(torso_rotation)
    left = cross(UP, forward)
    angle = math.degrees(math.atan2(float(direction @ left), float(direction @ forward)))
    if abs(angle) <= 45.0:
        return "front"
    if abs(angle) >= 135.0:
        return "back"
    return "left" if angle > 0 else "right"
