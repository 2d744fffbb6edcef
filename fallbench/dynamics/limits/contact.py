"""Contact limits at acceleration level (the authors' `ContactAccConstr`; 002 eq. 11 bounds the
contact body's velocity instead).

Every contact point's normal acceleration n'(J q_ddot + J_dot q_dot) is zero; tangential motion
is left to a cost (sliding released, 002 Sec. VII). The points of one body are redundant (four
corners of a flat foot give three independent rows), so the rows are combined per body into an
independent set, which keeps the equality block full rank for the solver. (A per-point
inequality, no point accelerating into the floor, was tried: the QP then tipped the feet and the
robot fell from every height.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.contacts import ContactKinematics
from fallbench.dynamics.kernels import independent_rows
from fallbench.dynamics.limits.limit import Limit, LimitRows, Space
from fallbench.dynamics.objective import SetPoint
from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.task import TaskTerms

RANK_TOLERANCE = 1e-6  # relative to a body's largest singular value


@dataclass
class ContactLimit(Limit):
    """Zero normal acceleration of every contact point measured with the state."""

    def compute(self, state: RobotState) -> LimitRows:
        """Independent rows R q_ddot = -r, equivalent to n'(J q_ddot + J_dot q_dot) = 0 at every point (m/s^2)."""
        contacts = state.contacts
        combined = independent_rows(
            contacts.normal_jacobian, contacts.normal_drift, contacts.body_of, RANK_TOLERANCE
        )
        return LimitRows.equal(Space.ACCELERATION, combined[:, :-1], -combined[:, -1])


def normal_motion_cost(kinematics: ContactKinematics, weight: float, dt: float) -> SetPoint:
    """Contact points neither sinking in nor lifting off within one control step, as a cost:
    weight |n'(J q_ddot + J_dot q_dot) + n'v / dt|^2."""
    motion = TaskTerms(np.zeros(len(kinematics.normals)), kinematics.normal_jacobian, kinematics.normal_drift)
    return SetPoint(weight, motion, 0.0, 1.0 / dt)


def tangential_motion_cost(kinematics: ContactKinematics, weight: float, dt: float) -> list[SetPoint]:
    """Soft no-slip: weight |T(J q_ddot + J_dot q_dot) + T v / dt|^2 with T = I - n n' per point, as two
    tasks: with T a projection |T x|^2 = |x|^2 - (n'x)^2, so the whole point motion at `weight` and the
    normal motion at -weight (no projected Jacobian is formed)."""
    whole = SetPoint(
        weight,
        TaskTerms(np.zeros(len(kinematics.drift)), kinematics.jacobian, kinematics.drift),
        0.0,
        1.0 / dt,
    )
    return [whole, normal_motion_cost(kinematics, -weight, dt)]
