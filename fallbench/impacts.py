"""What each impact looked like: which body groups met the environment, in which order, and the
arm posture and fall singularities (000 Sec. III) at that moment."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallbench.control.adaptive_gains_qp import select_motors
from fallbench.dynamics.contacts import environment_contacts
from fallbench.control.fall_singularity import Impact, singular_joints
from fallbench.dynamics.model import pinocchio_for
from fallbench.world import World


@dataclass
class ImpactEvent:
    t: float  # s, control step at which the group's first contact was seen
    group: str  # body group (feet, knees, hands, ...)
    bodies: list[str]
    elbow_angles: dict[str, float]  # rad per arm side
    singular: list[str]  # motors the impact forces leave unloaded


@dataclass
class FirstContact:
    t: float  # s
    point: np.ndarray  # m, world, mean of the body's contact points


@dataclass
class ImpactLog:
    world: World
    events: list[ImpactEvent] = field(default_factory=list)
    first_contacts: dict[str, FirstContact] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.P = pinocchio_for(self.world)
        self.group_of = {b: g for g, bodies in self.world.robot.body_groups.items() for b in bodies}

    def update(self, t: float, touching: set[str], data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray) -> None:
        """Log bodies touching for the first time (`touching` excludes the support at detection)."""
        new = sorted(b for b in touching if b not in self.first_contacts)
        if not new:
            return
        contacts = self._contacts(data, set(new))
        for body in new:
            points = [c.point for c in contacts if c.body == body]
            self.first_contacts[body] = FirstContact(t, np.mean(points, axis=0) if points else data.xpos[self.world.model.body(body).id].copy())
        logged = {e.group for e in self.events}
        for group in sorted({self.group_of.get(b, "other") for b in new} - logged):
            bodies = [b for b in new if self.group_of.get(b, "other") == group]
            self.events.append(self._event(t, group, bodies, [c for c in contacts if c.body in bodies], qpos, qvel))

    def _event(self, t: float, group: str, bodies: list[str], impacts: list[Impact], qpos: np.ndarray, qvel: np.ndarray) -> ImpactEvent:
        world = self.world
        elbows = {side: float(qpos[world.qpos_adr[world.joint_names.index(arm.elbow_joint)]])
                  for side, arm in world.robot.arms.items()}
        judged = [world.joint_names[i] for i in select_motors(self.P, set(bodies), world.joint_names)]
        q, _ = self.P.state(qpos, qvel)
        singular = singular_joints(self.P.model, self.P.data, q, impacts, judged) if impacts and judged else []
        return ImpactEvent(t, group, bodies, elbows, singular)

    def _contacts(self, data: mujoco.MjData, bodies: set[str]) -> list[Impact]:
        """Contact points of these bodies with the environment and the force on the robot there;
        the contact normal stands in for a force not yet built up."""
        model = self.world.model
        found, wrench = [], np.zeros(6)
        for point in environment_contacts(model, data, friction=0.0):
            if point.body not in bodies:
                continue
            mujoco.mj_contactForce(model, data, point.index, wrench)
            force = point.sign * data.contact[point.index].frame.reshape(3, 3).T @ wrench[:3]
            found.append(Impact(point.body, point.position, force if np.linalg.norm(force) >= 1e-6 else point.normal))
        return found

    def side_first_contact(self, side: str) -> tuple[str, FirstContact] | None:
        """The first contact of a hand body on this arm (a body on the chain through its shoulder)."""
        model = self.P.model
        shoulder = model.getJointId(self.world.robot.arms[side].shoulder_joint)
        hands = [b for b in self.world.robot.body_groups["hands"] if b in self.first_contacts
                 and shoulder in model.supports[model.frames[model.getFrameId(b)].parentJoint]]
        if not hands:
            return None
        body = min(hands, key=lambda b: self.first_contacts[b].t)
        return body, self.first_contacts[body]
