"""What each impact looked like: which body groups met the environment, in which order, and the
arm posture and fall singularities (000 Sec. III) at that moment."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallbench.dynamics.contacts import environment_contacts
from fallbench.dynamics.fall_singularity import Impact, singular_joints
from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.sim.world import World


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

    def update(
        self, t: float, touching: set[str], data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray
    ) -> None:
        """Log bodies touching for the first time (`touching` excludes the support at detection)."""
        new = sorted(b for b in touching if b not in self.first_contacts)
        if not new:
            return
        contacts = self._contacts(data, set(new))
        for body in new:
            points = [c.point for c in contacts if c.body == body]
            self.first_contacts[body] = FirstContact(
                t, np.mean(points, axis=0) if points else data.xpos[self.world.model.body(body).id].copy()
            )
        logged = {e.group for e in self.events}
        for group in sorted({self.group_of.get(b, "other") for b in new} - logged):
            bodies = [b for b in new if self.group_of.get(b, "other") == group]
            self.events.append(
                self._event(t, group, bodies, [c for c in contacts if c.body in bodies], qpos, qvel)
            )

    def _event(
        self,
        t: float,
        group: str,
        bodies: list[str],
        impacts: list[Impact],
        qpos: np.ndarray,
        qvel: np.ndarray,
    ) -> ImpactEvent:
        world = self.world
        elbows = {
            side: float(qpos[world.qpos_adr[world.joint_names.index(arm.elbow_joint)]])
            for side, arm in world.robot.arms.items()
        }
        judged = [world.joint_names[i] for i in select_motors(self.P, set(bodies), world.joint_names)]
        q, _ = self.P.state(qpos, qvel)
        singular = (
            singular_joints(self.P.model, self.P.data, q, impacts, judged) if impacts and judged else []
        )
        return ImpactEvent(t, group, bodies, elbows, singular)

    def _contacts(self, data: mujoco.MjData, bodies: set[str]) -> list[Impact]:
        """Contact points of these bodies with the environment and the force on the robot there;
        the contact normal stands in for a force not yet built up."""
        model = self.world.model
        found, wrench = [], np.zeros(6)
        contacts = environment_contacts(model, data, friction=0.0)
        for k, body in enumerate(contacts.bodies):
            if body not in bodies:
                continue
            index = int(contacts.index[k])
            mujoco.mj_contactForce(model, data, index, wrench)
            force = contacts.sign[k] * data.contact[index].frame.reshape(3, 3).T @ wrench[:3]
            found.append(
                Impact(
                    body,
                    contacts.positions[k],
                    force if np.linalg.norm(force) >= 1e-6 else contacts.normals[k],
                )
            )
        return found


def hand_first_contact(
    world: World, first_contacts: dict[str, FirstContact], side: str
) -> tuple[str, FirstContact] | None:
    """The first contact of a hand body on this arm (a body on the chain through its shoulder)."""
    model = pinocchio_for(world).model
    shoulder = model.getJointId(world.robot.arms[side].shoulder_joint)
    hands = [
        b
        for b in world.robot.body_groups["hands"]
        if b in first_contacts and shoulder in model.supports[model.frames[model.getFrameId(b)].parentJoint]
    ]
    if not hands:
        return None
    body = min(hands, key=lambda b: first_contacts[b].t)
    return body, first_contacts[body]


# ---------------------------------------------------------------- landing order against 000's prescriptions

KNEES_TOGETHER = 0.02  # s: both knees "at the same moment" (000 Sec. IV-B)


@dataclass(frozen=True)
class Touch:
    """A body's first contact with the environment after the fall was detected."""

    t: float  # s
    group: str  # body group: feet, knees, hands, arms (elbows), torso, head
    side: str  # "left"/"right": the limb the body hangs from; "" on the trunk


def body_sides(world: World) -> dict[str, str]:
    """Side of every contact body: the arm (shoulder joint) or leg (first joint) it hangs from."""
    model, robot = world.model, world.robot
    roots = {model.jnt_bodyid[model.joint(arm.shoulder_joint).id]: side for side, arm in robot.arms.items()}
    roots |= {model.jnt_bodyid[model.joint(joint).id]: side for side, (joint, *_) in robot.legs.items()}
    sides = {}
    for body in world.contact_bodies:
        b = model.body(body).id
        while b > 0 and b not in roots:
            b = model.body_parentid[b]
        sides[body] = roots.get(b, "")
    return sides


def touches(world: World, contact_times: dict[str, float]) -> list[Touch]:
    """The episode's first contacts per body, in time order, with their group and side."""
    group_of = {b: g for g, bodies in world.robot.body_groups.items() for b in bodies}
    sides = body_sides(world)
    return sorted(
        (Touch(t, group_of.get(b, "other"), sides.get(b, "")) for b, t in contact_times.items()),
        key=lambda touch: (touch.t, touch.group, touch.side),
    )


def _first(touches: list[Touch], group: str, side: str | None = None) -> float | None:
    return next((x.t for x in touches if x.group == group and (side is None or x.side == side)), None)


def _before(a: float | None, b: float | None) -> bool:
    """a happened, and strictly before b (or b never happened)."""
    return a is not None and (b is None or a < b)


def knees_simultaneous(touches: list[Touch]) -> float:
    """1.0 if both knees landed within KNEES_TOGETHER s, 0.0 if one knee landed alone (the other
    later or never), NaN when the knees did not land before the torso and head (not a knee landing)."""
    trunk = [t for t in (_first(touches, "torso"), _first(touches, "head")) if t is not None]
    knees = [_first(touches, "knees", side) for side in ("left", "right")]
    landed = [t for t in knees if t is not None]
    if not landed or (trunk and min(landed) >= min(trunk)):
        return float("nan")
    return float(len(landed) == 2 and abs(landed[0] - landed[1]) <= KNEES_TOGETHER + 1e-9)


def head_before_hands(touches: list[Touch]) -> bool:
    """The head touched, and before any hand (or no hand touched at all)."""
    return _before(_first(touches, "head"), _first(touches, "hands"))


def first_impact_prescribed(touches: list[Touch], fall_class: str) -> bool:
    """The landing order 000 prescribes for this class of fall (feet ignored: they are the support):

    - every class: never the elbows (upper arms) first (Sec. III, Def. 1);
    - `front`: the hands first, or both knees together (within 20 ms), never one knee alone;
      then the hands before the head (Sec. IV-B);
    - `back`: the hands (wrists) before the buttocks/torso and the head (Sec. IV-C);
    - `left`/`right`: no head contact, and that side's hand before the hip/torso (Sec. IV-D).
    """
    landing = [x for x in touches if x.group != "feet"]
    if not landing or fall_class not in ("front", "back", "left", "right"):
        return False
    first = {x.group for x in landing if x.t == landing[0].t}
    if "arms" in first:
        return False
    hands, torso, head = _first(landing, "hands"), _first(landing, "torso"), _first(landing, "head")
    if fall_class == "front":
        knees_together = knees_simultaneous(landing) == 1.0
        hands_first = "hands" in first and ("knees" not in first or knees_together)
        knees_first = "knees" in first and knees_together
        return first <= {"hands", "knees"} and (hands_first or knees_first) and _before(hands, head)
    if fall_class == "back":
        return _before(hands, torso) and _before(hands, head)
    return head is None and _before(_first(landing, "hands", fall_class), torso)
