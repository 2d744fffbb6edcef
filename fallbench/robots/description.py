"""What fallbench needs to know about a robot, independent of the simulator.

Everything robot-specific the rest of the code uses is a field here, filled from the robot's card
(fallbench/robots/card.py): no Python file names a joint or body of a particular robot
(tests/test_robot_names.py).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

SIDES = ("left", "right")
LEG_PITCH_PARTS = ("hip", "knee", "ankle")
DEFAULT_POSTURE = "default"  # every robot's nominal stance


@dataclass(frozen=True)
class GainGroup:
    """Default (stiff) PD gains for the joints whose name matches `pattern`."""

    pattern: str
    kp: float  # Nm/rad
    kd: float  # Nms/rad


@dataclass(frozen=True)
class Arm:
    """Joint and frame names of one arm, for the pre-impact reshaping (000 Sec. IV)."""

    shoulder_joint: str  # first arm joint: its origin is the shoulder
    elbow_joint: str
    wrist_joint: str  # its origin is the wrist point the landing tasks place
    wrist_frame: str  # body carrying the wrist point
    wrist_pitch_joint: str  # bent to pull the hand up, so that the wrist lands first
    hand_frame: str  # a body of the hand, to tell which way pulls the hand up


@dataclass(frozen=True)
class RobotDescription:
    """A robot: its URDF or MJCF (and SRDF), named postures, default gains and the bodies metrics talk about.

    A part the card leaves out is empty (`arms`, `feet`, `learned_gain_groups`): the methods that
    need it say so before any run (`missing`)."""

    name: str
    urdf_path: Path | None  # the robot's URDF; None for a robot given as an MJCF (`mjcf_path`)
    mesh_root: Path  # folder that `package://<package_prefix>` URIs point into
    package_prefix: str
    version: str  # version of the package that ships the description
    root_body: str
    torso_body: str  # body whose tilt detects falls and which is pushed by default
    imu_body: str  # the accelerometer sits at this body's origin, axes aligned with it (or at `imu_pose`)
    gain_groups: tuple[GainGroup, ...]
    body_groups: dict[str, tuple[str, ...]]  # metric group -> bodies (feet, knees, hands, arms, torso, head)
    legs: dict[str, tuple[str, ...]]  # "left"/"right" -> joints from the hip to the ankle
    arms: dict[str, Arm]  # "left"/"right" -> names; empty for a robot without arms
    leg_pitch_joints: dict[str, tuple[str, str]]  # "hip"/"knee"/"ankle" -> (left, right) pitch joints
    timeseries_joints: tuple[str, ...]  # joints whose angle and torque every run stores
    trajectory_joints: dict[str, str]  # joint -> label, drawn in the reshaped-fall figure
    vulnerable_parts: dict[
        str, tuple[str, ...]
    ]  # part a hit on counts as damage (SafeFall's vulnerable parts) -> its bodies
    torque_chains: dict[str, str]  # chain name -> regex of its joints, for per-chain torque peaks
    srdf_path: Path | None = None
    card_path: Path | None = None  # the card this description was read from
    fingerprint: str = ""  # hash of the card and the model files, part of every run's identity
    armature: dict[str, float] = field(default_factory=dict)  # joint -> kg m^2 reflected rotor inertia
    postures: dict[str, dict[str, float]] = field(default_factory=dict)  # must hold `default`
    posture_base_height: dict[str, float] = field(
        default_factory=dict
    )  # m, root height standing in a posture
    disabled_collisions: tuple[tuple[str, str], ...] = ()  # body pairs that never collide
    # the IMU's position (m) and orientation (w, x, y, z) in `imu_body`'s frame; None: its origin
    imu_pose: tuple[tuple[float, float, float], tuple[float, float, float, float]] | None = None
    # also disable the pairs touching in `default`, found when the robot is compiled (card: `auto`)
    disable_stance_contacts: bool = False
    # Columns: the robot's forward, left and up directions in the torso body's frame.
    torso_axes: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    feet: dict[str, str] = field(
        default_factory=dict
    )  # "left"/"right" -> the foot body that carries the sole
    # PD gains of the servo under a learned whole-fall policy (`onnx`): a compliant servo of the
    # kind learned policies are trained and deployed with, not the stiff default
    learned_gain_groups: tuple[GainGroup, ...] = ()
    # link -> its inertia tensor (ixx, ixy, ixz, iyy, iyz, izz, kg m^2) in place of the URDF's: a fix
    # both MuJoCo and Pinocchio read, as they both read `urdf_text`
    inertia_overrides: dict[str, tuple[float, ...]] = field(default_factory=dict)
    # whether the card gives `standing_height`; if not, the height is derived by settling the robot
    # (fallbench/sim/settle.py), which puts it into `posture_base_height`
    standing_height_given: bool = True
    mjcf_path: Path | None = None  # the robot's MJCF, when it is given as one (fallbench/robots/mjcf.py)
    model_mass: float | None = None  # kg, an MJCF's mass as MuJoCo compiles it (None: the URDF's <mass>es)

    @property
    def model_path(self) -> Path:
        """The robot's model file: its URDF or its MJCF."""
        path = self.mjcf_path or self.urdf_path
        assert path is not None, "a robot has a URDF or an MJCF"
        return path

    @property
    def model_kind(self) -> str:
        """ "URDF" or "MJCF": how messages name the model file."""
        return "URDF" if self.mjcf_path is None else "MJCF"

    def missing(self, fields: tuple[str, ...]) -> str | None:
        """The first of `fields` (names of this class's fields) that the robot leaves empty, else None."""
        return next((name for name in fields if not getattr(self, name)), None)

    @property
    def vulnerable_bodies(self) -> tuple[str, ...]:
        """Every body of every vulnerable part."""
        return tuple(body for bodies in self.vulnerable_parts.values() for body in bodies)

    def urdf_text(self) -> str:
        """The URDF with package URIs resolved to files on this machine and the card's inertia
        overrides applied; ValueError for a robot given as an MJCF."""
        if self.urdf_path is None:
            raise ValueError(f"robot {self.name!r} is given as an MJCF, not a URDF")
        text = self.urdf_path.read_text()
        for link, tensor in self.inertia_overrides.items():
            text = override_inertia(text, link, tensor)
        return resolve_package_uris(text, self.package_prefix, self.mesh_root)

    def default_gains(self, joint: str) -> tuple[float, float]:
        for group in self.gain_groups:
            if re.fullmatch(group.pattern, joint):
                return group.kp, group.kd
        raise KeyError(f"robot {self.name!r}: no default gains for joint {joint!r}")

    def learned_gains(self, joint: str) -> tuple[float, float]:
        """(Nm/rad, Nms/rad) of `joint`'s servo under a learned whole-fall policy."""
        for group in self.learned_gain_groups:
            if re.fullmatch(group.pattern, joint):
                return group.kp, group.kd
        raise KeyError(f"robot {self.name!r}: no learned-policy gains for joint {joint!r}")

    @property
    def knee_joints(self) -> tuple[str, str]:
        return self.leg_pitch_joints["knee"]

    @property
    def leg_joints(self) -> tuple[str, ...]:
        return tuple(joint for side in SIDES for joint in self.legs[side])

    def leg_pitch(self, side: str) -> dict[str, str]:
        """ "hip"/"knee"/"ankle" -> the pitch joint of one leg."""
        return {part: self.leg_pitch_joints[part][SIDES.index(side)] for part in LEG_PITCH_PARTS}

    @property
    def contact_candidates(self) -> tuple[str, ...]:
        """Bodies whose contacts with the environment are sensed (those with collision geometry)."""
        return tuple(body for bodies in self.body_groups.values() for body in bodies)

    def torso_frame(self, rotation: np.ndarray) -> np.ndarray:
        """World rotation of the torso body -> columns forward, left, up of the robot in the world."""
        return rotation @ np.array(self.torso_axes).T

    def torso_axis(self, name: str) -> np.ndarray:
        """ "forward"/"left"/"up" in the torso body's frame."""
        return np.array(self.torso_axes[("forward", "left", "up").index(name)])

    @cached_property
    def mass(self) -> float:
        """kg, sum of the URDF's link masses, or the MJCF's mass."""
        if self.model_mass is not None:
            return self.model_mass
        return sum(float(m.attrib["value"]) for m in ET.fromstring(self.model_path.read_text()).iter("mass"))

    @property
    def standing_height_known(self) -> bool:
        """Whether the standing height is here: given by the card, or derived in this process."""
        return DEFAULT_POSTURE in self.posture_base_height

    @property
    def standing_height(self) -> float:
        """m, root height standing in `default`: the robot's length scale; StandingHeightUnknown for
        a card that leaves it out before it is derived (`fallbench.sim.settle.ensure_standing_height`)."""
        if not self.standing_height_known:
            raise StandingHeightUnknown(self.unknown_height_reason())
        return self.posture_base_height[DEFAULT_POSTURE]

    def unknown_height_reason(self) -> str:
        """What an unknown standing height is, for messages."""
        return (
            f"robot {self.name!r}: its card gives no standing_height and this process has not derived it "
            "(fallbench's commands derive it by settling the robot when they load or run it, and cache "
            f"it; `fallbench robots check {self.card_path}` shows it)"
        )


class StandingHeightUnknown(ValueError):
    """A card leaves `standing_height` out and nothing has derived it yet in this process."""


def resolve_package_uris(text: str, prefix: str, root: Path) -> str:
    """A URDF's text with `package://<prefix>` URIs turned into paths inside `root`."""
    return re.sub(rf"package:///?{re.escape(prefix)}", str(root) + "/", text)


INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def link_block(text: str, link: str) -> re.Match[str] | None:
    """The <link> element named `link` in a URDF's text."""
    return re.search(rf"""<link\s+name=(["']){re.escape(link)}\1[^>]*?(/>|>.*?</link>)""", text, re.S)


def override_inertia(text: str, link: str, tensor: tuple[float, ...]) -> str:
    """`text` with the <inertia> of `link` replaced by `tensor` (INERTIA_KEYS order); every other
    byte as it was."""
    block = link_block(text, link)
    if block is None:
        raise KeyError(f"no link {link!r} in the URDF")
    element = "<inertia " + " ".join(f'{k}="{v!r}"' for k, v in zip(INERTIA_KEYS, tensor)) + "/>"
    new, count = re.subn(r"<inertia\s[^>]*?/>", element, block.group(0), count=1)
    if not count:
        raise KeyError(f"link {link!r} has no <inertia> in the URDF")
    return text[: block.start()] + new + text[block.end() :]


def read_srdf_postures(srdf_path: Path) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """Named group states of an SRDF: joint values, and the root joint's height when given."""
    root = ET.parse(srdf_path).getroot()
    postures: dict[str, dict[str, float]] = {}
    heights: dict[str, float] = {}
    for state in root.iter("group_state"):
        name = state.attrib["name"]
        joints: dict[str, float] = {}
        for joint in state.iter("joint"):
            values = [float(v) for v in joint.attrib["value"].split()]
            if len(values) == 7:  # free-flyer: x y z qx qy qz qw
                heights[name] = values[2]
            else:
                joints[joint.attrib["name"]] = values[0]
        postures[name] = joints
    return postures, heights


def read_srdf_disabled_collisions(srdf_path: Path) -> tuple[tuple[str, str], ...]:
    root = ET.parse(srdf_path).getroot()
    return tuple((e.attrib["link1"], e.attrib["link2"]) for e in root.iter("disable_collisions"))


def read_srdf_armature(srdf_path: Path) -> dict[str, float]:
    """Reflected rotor inertia (rotor inertia x gear ratio^2) per joint from `rotor_params`."""
    root = ET.parse(srdf_path).getroot()
    return {
        j.attrib["name"]: float(j.attrib["mass"]) * float(j.attrib["gear_ratio"]) ** 2
        for j in root.iter("joint")
        if "gear_ratio" in j.attrib
    }
