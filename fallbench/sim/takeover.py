"""The takeover schedule of one episode: which motors follow the gain policy, since when, toward
which pose, and the switches waiting for the takeover latency.

Every motor switches to the gain policy at the first impact, unless the pre-impact strategy
switches per chain (`reshape`): then a motor switches when a body on its chain to the root touches
the environment (002 Sec. V, last paragraph); the others go on under the strategy until the torso
or head lands, when all switch, or at the latest `timing.handover_after` s after the first impact
(a fall that ends on hands and knees never lands on the torso: 002 does not say what follows it).
The motors of an impact switch `timing.takeover_latency` s after it, whatever the physics step.
"""

from __future__ import annotations

import math

import numpy as np

from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.scenario import Timing
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World

LANDED_GROUPS = ("torso", "head")  # a contact here ends pre-impact reshaping for every motor


class Takeover:
    """Which motors follow the gain policy, since when, and toward which pose (002 Sec. V: q_ref is
    the configuration just before impact, taken per motor when it switches); and the switches
    scheduled by impacts, falling due after the latency."""

    def __init__(self, world: World, timing: Timing, per_chain: bool) -> None:
        nu = world.model.nu
        self.switched = np.zeros(nu, dtype=bool)
        # whether any motor, and every motor, has switched: read at every control step (`switch` sets them)
        self.any_switched, self.all_switched = False, bool(self.switched.all())
        self.time = np.full(nu, np.nan)  # s per motor, NaN = never
        self.q_ref: np.ndarray | None = None
        self.due: list[tuple[float, np.ndarray]] = []  # (s, motors): switches waiting for the latency
        self.world, self.timing, self.per_chain = world, timing, per_chain
        self.pinocchio = pinocchio_for(world)
        self.landed_bodies = {b for g in LANDED_GROUPS for b in world.robot.body_groups.get(g, ())}

    def schedule(self, touched: float, new: set[str], first: bool) -> None:
        """Schedule the switch of the motors of the bodies `new` that touched at `touched` (s): all
        motors, unless the strategy switches per chain; `first`: the first impact of the fall."""
        every = np.ones(len(self.switched), dtype=bool)
        if first and self.per_chain:  # a fall that never lands on the torso ends too
            self.due.append((touched + self.timing.handover_after, every))
        everything = not self.per_chain or new & self.landed_bodies
        now = every if everything else np.zeros_like(self.switched)
        now[select_motors(self.pinocchio, new, self.world.joint_names)] = True
        self.due.append((touched + self.timing.takeover_latency, now))

    def due_at(self) -> float:
        """s: the earliest scheduled switch (less a rounding margin), inf if none is waiting."""
        return min(when for when, _ in self.due) - 1e-9 if self.due else math.inf

    def take_over(self, t: float, q: np.ndarray) -> bool:
        """Switch the motors whose latency has passed at `t` (s), toward `q`; True if any did."""
        ready = [motors for when, motors in self.due if when <= t + 1e-9]
        self.due = [(when, motors) for when, motors in self.due if when > t + 1e-9]
        return any([self.switch(motors, q, t) for motors in ready])

    def switch(self, now: np.ndarray, q: np.ndarray, t: float) -> bool:
        """Switch the motors of `now` that have not switched yet; True if any did."""
        fresh = now & ~self.switched
        if not fresh.any():
            return False
        self.q_ref = np.where(fresh, q, self.q_ref if self.q_ref is not None else q)
        self.time[fresh] = t
        self.switched = self.switched | now
        self.any_switched, self.all_switched = bool(self.switched.any()), bool(self.switched.all())
        return True

    def compose(self, policy: ServoCommand, other: ServoCommand) -> ServoCommand:
        """Switched motors follow the gain policy, the others the pre-impact command."""
        if self.all_switched:
            return policy
        return ServoCommand(
            *(
                np.where(self.switched, a, b)
                for a, b in zip(
                    (policy.kp, policy.kd, policy.q_ref, policy.qd_ref),
                    (other.kp, other.kd, other.q_ref, other.qd_ref),
                )
            )
        )
