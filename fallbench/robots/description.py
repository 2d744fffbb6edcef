"""What fallbench needs to know about a robot, independent of the simulator."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path


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
    """A robot: its URDF/SRDF, named postures, default gains and the bodies metrics talk about."""

    name: str
    urdf_path: Path
    srdf_path: Path
    mesh_root: Path  # folder that `package://<package_prefix>` URIs point into
    package_prefix: str
    version: str  # version of the package that ships the description
    root_body: str
    torso_body: str  # body whose tilt detects falls and which is pushed by default
    imu_body: str
    knee_joints: tuple[str, ...]
    gain_groups: tuple[GainGroup, ...]
    body_groups: dict[str, tuple[str, ...]]  # metric group -> bodies (feet, knees, hands, ...)
    armature: dict[str, float] = field(default_factory=dict)  # joint -> kg m^2 reflected rotor inertia
    postures: dict[str, dict[str, float]] = field(default_factory=dict)
    posture_base_height: dict[str, float] = field(default_factory=dict)
    disabled_collisions: tuple[tuple[str, str], ...] = ()
    arms: dict[str, Arm] = field(default_factory=dict)  # "left"/"right" -> names
    leg_pitch_joints: dict[str, tuple[str, ...]] = field(default_factory=dict)  # "hip"/"knee"/"ankle" -> both legs
    vulnerable_parts: dict[str, tuple[str, ...]] = field(default_factory=dict)  # part a hit on counts as damage -> its bodies
    torque_chains: dict[str, str] = field(default_factory=dict)  # chain name -> regex of its joints, for per-chain torque peaks

    def urdf_text(self) -> str:
        """The URDF with package URIs resolved to files on this machine."""
        text = self.urdf_path.read_text()
        return re.sub(rf"package:///?{re.escape(self.package_prefix)}", str(self.mesh_root) + "/", text)

    def default_gains(self, joint: str) -> tuple[float, float]:
        for group in self.gain_groups:
            if re.fullmatch(group.pattern, joint):
                return group.kp, group.kd
        raise KeyError(f"robot {self.name!r}: no default gains for joint {joint!r}")


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
