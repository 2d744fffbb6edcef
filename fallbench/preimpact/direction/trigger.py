"""The control trigger of 004 Sec. III-D (Fig. 3): control starts once the robot's tipping is
steady, i.e. the last capture points (`events.capture_point`) lie on a straight line, or at a
time limit after the fall trigger."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def collinearity(points: np.ndarray) -> tuple[float, float]:
    """(RMS distance of the points from their best-fit line, m; extent along the line, m)."""
    centred = points - points.mean(axis=0)
    _, singular, axes = np.linalg.svd(centred, full_matrices=False)
    along = centred @ axes[0]
    rms = float(singular[1] / math.sqrt(len(points))) if len(singular) > 1 else 0.0
    return rms, float(along.max() - along.min())


@dataclass
class ControlTrigger:
    """Fires once the last `window` capture points are collinear within `tolerance` (m RMS) over at
    least `min_travel` (m), or `timeout` s after the fall trigger."""

    window: int
    tolerance: float  # m
    min_travel: float  # m
    timeout: float  # s
    points: list[np.ndarray] = field(default_factory=list)
    started: float | None = None
    time: float | None = None
    reason: str = ""

    def update(self, t: float, xi: np.ndarray) -> bool:
        if self.time is not None:
            return True
        if self.started is None:
            self.started = t
        self.points.append(np.asarray(xi[:2], dtype=float))
        if len(self.points) >= self.window:
            rms, travel = collinearity(np.array(self.points[-self.window :]))
            if rms <= self.tolerance and travel >= self.min_travel:
                self.time, self.reason = t, "steady"
        if self.time is None and t - self.started >= self.timeout - 1e-9:
            self.time, self.reason = t, "timeout"
        return self.time is not None
