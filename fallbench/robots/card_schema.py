"""The robot card's schema: every key, its type and range (pydantic, versioned; unknown keys
rejected). `fallbench/robots/card.py` reads a card with it and checks it against the model; the
format, key by key: docs/robots.md."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator

from fallbench.yamlfile import Strict

CARD_SCHEMA_VERSION = 1  # of the card format; a card states the version it is written for

Name = Annotated[str, Field(min_length=1, max_length=200)]
Names = tuple[Name, ...]
Radians = Annotated[float, Field(ge=-6.3, le=6.3)]
Axis = tuple[float, float, float]


class ModelFiles(Strict):
    """Where the robot's model files are."""

    urdf: Name | None = None  # path relative to `root` ...
    mjcf: Name | None = None  # ... or an MJCF (MuJoCo XML) of the robot: one of the two
    srdf: Name | None = None  # optional: postures (group states), disabled collisions, rotor parameters
    keyframes: Name | None = None  # optional: an MJCF of the robot whose named <key>s are postures
    package: Name | None = None  # installed Python distribution holding the files; default: the card's folder
    root: Name = "."  # folder inside `package` (or the card's folder) that the paths are relative to
    package_uri: str = ""  # `package://<package_uri>` in the URDF points into `root` (a URDF's only)


class Inertia(Strict):
    """A link's inertia tensor about its centre of mass, kg m^2, in the URDF's <inertia> terms."""

    ixx: float
    ixy: float
    ixz: float
    iyy: float
    iyz: float
    izz: float


class ImuSite(Strict):
    """The IMU as a frame on a body: the accelerometer and gyro sit at `pos`, their axes turned by
    `rpy` (the URDF's roll, pitch, yaw about the body's fixed x, y, z axes)."""

    body: Name
    pos: Axis = (0.0, 0.0, 0.0)  # m, in the body's frame
    rpy: Axis = (0.0, 0.0, 0.0)  # rad


class Gains(Strict):
    kp: Annotated[float, Field(gt=0, le=1e6)]  # Nm/rad
    kd: Annotated[float, Field(ge=0, le=1e6)]  # Nms/rad


class Pair(Strict):
    left: Name
    right: Name


class Legs(Strict):
    left: Annotated[Names, Field(min_length=1)]  # joints from the hip to the ankle
    right: Annotated[Names, Field(min_length=1)]


class ArmNames(Strict):
    shoulder_joint: Name  # first arm joint: its origin is the shoulder
    elbow_joint: Name
    wrist_joint: Name  # its origin is the wrist point the landing tasks place
    wrist_frame: Name  # body carrying the wrist point
    wrist_pitch_joint: Name  # bent to pull the hand up, so that the wrist lands first
    hand_frame: Name  # a body of the hand


class Arms(Strict):
    left: ArmNames
    right: ArmNames


class LegPitch(Strict):
    hip: Pair
    knee: Pair
    ankle: Pair


class BodyGroups(Strict):
    """Metric group -> bodies, each a link name or a regular expression over the link names."""

    feet: Annotated[Names, Field(min_length=1)]
    knees: Names = ()
    hands: Names = ()
    arms: Names = ()
    torso: Names = ()
    head: Names = ()


class TorsoAxes(Strict):
    """The robot's directions in the torso body's frame."""

    forward: Axis = (1.0, 0.0, 0.0)
    left: Axis = (0.0, 1.0, 0.0)
    up: Axis = (0.0, 0.0, 1.0)


class RobotCard(Strict):
    schema_version: int
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]{1,64}$")]  # also in file names of caches
    model: ModelFiles
    root_body: Name  # the floating base
    torso_body: Name  # whose tilt detects falls; pushed by default
    imu_body: Name | None = None  # the accelerometer sits at its origin, axes aligned with it ...
    imu_site: ImuSite | None = None  # ... or at a frame on a body (one of the two)
    # m, root height standing in `default`; left out: derived by settling the robot (sim/settle.py)
    standing_height: Annotated[float, Field(gt=0, le=10)] | None = None
    default_posture: Name | None = None  # the posture that is `default` (the nominal stance), by name
    postures: dict[Name, dict[Name, Radians]] = {}  # name -> joint -> rad (the SRDF's are added)
    gains: Annotated[dict[Name, Gains], Field(min_length=1)]  # joint regex -> stiff PD gains, first match
    learned_gains: dict[Name, Gains] = {}  # joint regex -> servo gains under a learned policy
    armature: dict[Name, Annotated[float, Field(ge=0, le=100)]] = {}  # joint or regex -> kg m^2
    # body pairs never in contact; `auto` (alone or as an entry): also the pairs touching in `default`
    disabled_collisions: Literal["auto"] | tuple[Literal["auto"] | tuple[Name, Name], ...] = ()
    inertia_overrides: dict[Name, Inertia] = {}  # link -> tensor replacing the URDF's (a fix to its data)
    body_groups: BodyGroups
    legs: Legs
    leg_pitch_joints: LegPitch
    arms: Arms | None = None
    feet: Pair | None = None  # the bodies carrying the soles
    timeseries_joints: Names = ()  # joints whose angle and torque every run stores
    trajectory_joints: dict[Name, Name] = {}  # joint -> label in the reshaped-fall figure
    vulnerable_parts: dict[Name, Names] = {}  # part -> bodies (names or regexes) a hit on damages
    torque_chains: dict[Name, Name] = {}  # chain -> joint regex, for per-chain torque peaks
    torso_axes: TorsoAxes = TorsoAxes()

    @field_validator("schema_version")
    @classmethod
    def _known_version(cls, value: int) -> int:
        if value != CARD_SCHEMA_VERSION:
            raise ValueError(f"this fallbench reads robot cards of schema version {CARD_SCHEMA_VERSION}")
        return value
