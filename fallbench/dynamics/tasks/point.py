"""Point task: a point fixed in a body toward a world position, along some of the world axes
(000 Sec. IV-C: the wrists below the buttocks, along the vertical only)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.task import Task, TaskTerms


@dataclass
class PointTask(Task):
    point: BodyPoint
    target: np.ndarray  # m, world (the coordinates off `axes` are ignored)
    axes: slice = field(default_factory=lambda: slice(0, 3))  # world axes controlled, x y z = 0 1 2

    def compute(self, state: RobotState) -> TaskTerms:
        """g = (p - target) on the axes (m), J and J_dot q_dot of the point on the same axes."""
        position, jacobian, drift = self.point.kinematics(state)
        return TaskTerms((position - self.target)[self.axes], jacobian[self.axes], drift[self.axes])
