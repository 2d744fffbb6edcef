"""The swing foot's path for Take a Step (004 Sec. IV-B-1) and when the step ends (Sec. VI).

Lift straight up first (a loaded foot pushed sideways would move the body instead), then over to
the target at the lift height, then down onto it; once on its way down the foot stays on its way
down (the target keeps being corrected horizontally). The step ends when the lifted foot is back on
the ground, wherever that is: a foot that touches down beside its target carries the robot there and
cannot be swung again. 004 Sec. VI calls a step whose foot meets the ground before its target
"incomplete"; whether it landed close enough is the caller's measure (`step_tolerance`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LANDED = 0.015  # m: a descending foot frame this close to its standing height has landed (the ground tilts under a falling robot)


@dataclass
class SwingPath:
    home: np.ndarray  # m, (3,) the swing foot frame standing on the ground
    target_xy: np.ndarray  # m, (2,) where the foot frame is to land
    lift_height: float  # m above `home`
    descend_within: float  # m: the foot starts down this close to the target, horizontally
    lifted: bool = False  # the foot has left the ground
    descending: bool = False

    def waypoint(self, position: np.ndarray) -> np.ndarray:
        """The point (m, (3,) world) the foot frame, now at `position`, moves toward; advances the phase."""
        self.lifted = self.lifted or position[2] >= self.home[2] + 0.5 * self.lift_height
        if not self.lifted:
            return np.array([position[0], position[1], self.home[2] + self.lift_height])
        self.descending = (
            self.descending or float(np.linalg.norm(self.target_xy - position[:2])) <= self.descend_within
        )
        return np.array([*self.target_xy, self.home[2] + (0.0 if self.descending else self.lift_height)])

    def landed(self, position: np.ndarray, touching: bool) -> bool:
        """Whether the lifted foot is back on the ground: touching it, or down at its standing height."""
        return self.lifted and (touching or (self.descending and position[2] <= self.home[2] + LANDED))
