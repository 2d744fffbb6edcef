"""Relative-distance task (002 eqs. 6-9): two body points reach their surfaces at the same time.

Each pair is a body point and a planar surface (a point on it and its unit normal). The distance
is measured along the surface normal, d_i = n_i . (p_i - s_i); the error is d_1 - d_2, so the
task leaves the motion along the surfaces free (the surface-position task handles that).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.task import Task, TaskTerms


@dataclass
class SurfacePair:
    point: BodyPoint
    surface_point: np.ndarray  # m, world
    normal: np.ndarray  # unit, world, out of the surface


@dataclass
class RelativeDistanceTask(Task):
    first: SurfacePair
    second: SurfacePair

    def compute(self, state: RobotState) -> TaskTerms:
        """Error d_1 - d_2 (m, (1,)), Jacobian (1, nv) and drift (m/s^2, (1,)): eq. 7, eq. 8 and eq. 9."""
        error, jacobian, drift = 0.0, np.zeros(state.model.nv), 0.0
        for sign, pair in ((1.0, self.first), (-1.0, self.second)):
            position, J, J_dot_v = pair.point.kinematics(state)
            error += sign * float(pair.normal @ (position - pair.surface_point))
            jacobian += sign * pair.normal @ J
            drift += sign * float(pair.normal @ J_dot_v)
        return TaskTerms(np.array([error]), jacobian[None, :], np.array([drift]))
