"""The scenario schema: every field of a scenario (pydantic, a documented range on every number),
the scenario file's sweep fields on top, the error of bad scenario input, and a controller's
parameters resolved against a scenario's `policy_params`."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, field_validator, model_validator

from fallbench.robots import DEFAULT_ROBOT
from fallbench.robots.description import DEFAULT_POSTURE
from fallbench.yamlfile import FieldProblem, InputError, Strict

# Every number of a scenario is finite (Strict's allow_inf_nan=False) and within a documented
# range (docs/scenarios.md, "Ranges"): give each new numeric field bounds (test_scenario_ranges checks that
# every numeric field of the schema has a lower and an upper one).
MAX_STEPS_PER_RUN = 200_000  # physics steps (duration / physics_dt) of one run: ~10-15 s of wall time
MAX_POINTS_PER_FILE = 10_000  # sweep points x seeds of one scenario file
MAX_TEXT = 200  # characters of a name

Seconds = Annotated[float, Field(gt=0, le=60)]  # durations, s
Time = Annotated[float, Field(ge=0, le=60)]  # instants, s
Degrees = Annotated[float, Field(ge=-360, le=360)]
Position = Annotated[float, Field(ge=-20, le=20)]  # m: the floor is 40 m x 40 m
Size = Annotated[float, Field(gt=0, le=10)]  # m
Name = Annotated[str, Field(min_length=1, max_length=MAX_TEXT)]


class Initial(Strict):
    posture: Name = DEFAULT_POSTURE  # a posture of the robot; every robot has `default`, its nominal stance
    height: Annotated[float, Field(ge=0, le=10)] = 0.0  # m between the feet and the floor at t = 0
    joints: dict[Name, Annotated[float, Field(ge=-6.3, le=6.3)]] = {}  # rad, overrides of the posture
    joint_noise: Annotated[float, Field(ge=0, le=0.5)] = (
        0.0  # rad, half-width of a uniform offset per joint outside the legs, drawn from the seed
    )


class Push(Strict):
    force: Annotated[float, Field(ge=0, le=10_000)]  # N
    direction: Degrees = 0.0  # deg in the ground plane; 0 = robot forward, 90 = robot left
    duration: Seconds = 0.2  # s
    start: Time = 0.1  # s
    body: Name | None = None  # default: the robot's torso


class Box(Strict):
    type: Literal["box"]
    pos: tuple[Position, Position, Position]  # m, centre in the world
    size: tuple[Size, Size, Size]  # m, full extents
    yaw: Degrees = 0.0  # deg


class Cylinder(Strict):
    type: Literal["cylinder"]
    pos: tuple[Position, Position, Position]  # m, centre in the world
    radius: Annotated[float, Field(gt=0, le=5)]  # m
    height: Size  # m


Obstacle = Annotated[Box | Cylinder, Field(discriminator="type")]


DetectionMethod = Literal["capture_point", "tilt", "freefall"]


class Detection(Strict):
    # Detectors that may declare the fall; the earliest to fire wins (see fallbench/events.py).
    method: Annotated[tuple[DetectionMethod, ...], Field(min_length=1)] = (
        "capture_point",
        "tilt",
        "freefall",
    )
    capture_point_margin: Annotated[float, Field(ge=-1, le=1)] = (
        0.02  # m the capture point must be outside the feet's support polygon
    )
    tilt: Annotated[float, Field(gt=0, lt=90)] = 15.0  # deg of torso tilt that declares a fall (000)
    freefall: Annotated[float, Field(ge=0, le=9.81)] = (
        3.0  # m/s^2: accelerometer norm below this declares free fall
    )
    freefall_hold: Annotated[float, Field(ge=0, le=10)] = 0.02  # s the accelerometer must read free fall
    # A strategy that acted on a fall that does not go on hands back to the stance controller
    # (docs/detection.md#false-alarms): the capture point at least `hand_back_margin` m inside the
    # feet's support polygon and the torso tilt under `tilt` for `hand_back_hold` s, before any
    # body other than the feet touched.
    # Detectors whose firing starts a pre-impact strategy (the declared detection, or later, up
    # to the first touch of a body other than the feet): free fall alone is no topple, a drop may
    # land on its feet. A whole-fall controller starts at the declared detection.
    act_on: Annotated[tuple[Literal["capture_point", "tilt"], ...], Field(min_length=1)] = (
        "capture_point",
        "tilt",
    )
    hand_back: bool = True
    hand_back_margin: Annotated[float, Field(ge=0, le=0.5)] = 0.0  # m
    hand_back_hold: Annotated[float, Field(gt=0, le=2)] = 0.1  # s

    @field_validator("method", "act_on", mode="before")
    @classmethod
    def _one_or_many(cls, value: Any) -> Any:
        return (value,) if isinstance(value, str) else value


DEFAULT_PHYSICS_DT = 0.0005  # s (see Scenario.physics_dt)


class Timing(Strict):
    """Delays of the robot's controller, in seconds (never in physics steps)."""

    # s from the first contact the robot's contact sensing sees to the gain policy's takeover:
    # one period of 002's 5 ms control loop (the contact is read at one tick, the new gains are
    # written at the next). With 0, the takeover comes one physics step after the contact.
    takeover_latency: Annotated[float, Field(ge=0, le=0.1)] = 0.005
    # s from the first impact to the switch of every motor, for a strategy that switches per chain
    # (`reshape`) in a fall whose torso and head never land (on hands and knees, against an object):
    # without it the strategy reshapes a robot lying still for ever. 2 s: the torso lands within
    # 1.94 s of the first impact in the main job's reshaped falls that land on it (docs/simulation.md).
    handover_after: Annotated[float, Field(gt=0, le=10)] = 2.0


class Contact(Strict):
    """Contact and joint-stop softness: MuJoCo's solref (time constant, damping ratio) and solimp
    (impedance), on every robot, floor and obstacle geom alike, so a softer floor and a padded robot
    are the same setting (MuJoCo mixes the two sides of a contact)."""

    # s. 12.5 ms is what robot-environment contacts had before this was a parameter: robot geoms
    # 5 ms mixed half and half with the floor's MuJoCo default of 20 ms.
    time_constant: Annotated[float, Field(ge=0.0005, le=0.5)] = 0.0125
    damping_ratio: Annotated[float, Field(gt=0, le=10)] = 1.0
    # solimp (d0, d_width, width m): constraint impedance at zero and full penetration, and the
    # penetration (m) between them
    impedance: tuple[
        Annotated[float, Field(ge=0.0001, le=0.9999)],
        Annotated[float, Field(ge=0.0001, le=0.9999)],
        Annotated[float, Field(gt=0, le=0.1)],
    ] = (0.9, 0.95, 0.001)
    stop_time_constant: Annotated[float, Field(ge=0.0005, le=0.5)] = 0.005  # s, joint limits
    stop_damping_ratio: Annotated[float, Field(gt=0, le=10)] = 1.0


DEFAULT_CAP = 10.0  # s: the longest a run may take to come to rest (see Scenario.duration)


class Rest(Strict):
    """When a run has come to rest and ends (fallbench/sim/rest.py): after the last disturbance
    (the push's end), the base's linear and angular speed and every joint's speed stay under these
    thresholds for `hold` seconds. Chosen from the shipped falls (docs/simulation.md, "Runs end
    at rest"): a standing TALOS sways at up to ~0.05 m/s for a few seconds after a disturbance;
    robots lying on the floor under any policy go under 0.01 m/s and 0.1 rad/s per joint."""

    linear_speed: Annotated[float, Field(gt=0, le=10)] = 0.1  # m/s, the root body's
    angular_speed: Annotated[float, Field(gt=0, le=50)] = 0.3  # rad/s, the root body's
    joint_speed: Annotated[float, Field(gt=0, le=100)] = 0.5  # rad/s, every actuated joint
    hold: Annotated[float, Field(gt=0, le=10)] = 1.0  # s all three must hold


class Sensors(Strict):
    """The sensor models the headline metrics read (fallbench/analysis/sensors.py)."""

    imu_rate: Annotated[float, Field(gt=0, le=100_000)] = 1000.0  # Hz output rate (MPU-6000: 1 kHz)
    imu_bandwidth: Annotated[float, Field(gt=0, le=50_000)] = 184.0  # Hz, -3 dB (MPU-6000 DLPF_CFG 1)
    imu_filter_order: Annotated[int, Field(ge=1, le=8)] = 2  # Butterworth order (the datasheet gives none)
    force_window: Annotated[float, Field(gt=0, le=1)] = 0.005  # s over which peak forces are averaged


MAX_PARAM = 1e6  # |value| of a policy parameter


def _param_value(value: Any) -> Any:
    """A policy parameter: a flag, a name, a finite number within +-MAX_PARAM, or a list of them
    (each policy checks its own parameters' meaning)."""
    if isinstance(value, list):
        if len(value) > 64:
            raise ValueError(f"must be a list of at most 64 values (got {len(value)})")
        return [_param_value(v) for v in value]
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, str):
        if len(value) > MAX_TEXT:
            raise ValueError(f"must be a name of at most {MAX_TEXT} characters")
        return value
    if isinstance(value, (int, float)):
        if not math.isfinite(value) or abs(value) > MAX_PARAM:
            raise ValueError(f"must be a finite number within +-{MAX_PARAM:g}")
        return value
    raise ValueError(f"must be a number, a flag, a name or a list of them (got a {type(value).__name__})")


ParamValue = Annotated[Any, AfterValidator(_param_value)]


class Scenario(Strict):
    """One fully resolved scenario point (no sweep left)."""

    name: Name
    # a shipped robot's name, or the absolute path of a robot card (a file gives it relative to itself);
    # default: files written before other robots existed describe TALOS
    robot: Annotated[str, Field(min_length=1, max_length=4096)] = DEFAULT_ROBOT
    # s: the cap. A run ends once the robot has come to rest (`rest`), or at the cap, flagged as
    # not settled; every whole-run measure is read over the run to rest.
    duration: Seconds = DEFAULT_CAP
    # s. 0.5 ms: on the 002 drops (both robots, four policies) halving it moves the landing IMU peak
    # by 0.9 % median and 3.8 % at worst; from 1 ms the same halving moved it 19.5 % at worst
    # (a knee-stop slam of `zero`), see `fallbench converge` and docs/simulation.md.
    physics_dt: Annotated[float, Field(ge=1e-4, le=0.01)] = DEFAULT_PHYSICS_DT
    control_dt: Annotated[float, Field(ge=1e-4, le=0.1)] = 0.005  # s
    friction: Annotated[float, Field(gt=0, le=5)] = 0.7
    initial: Initial = Initial()
    push: Push | None = None
    obstacles: Annotated[list[Obstacle], Field(max_length=64)] = []
    detection: Detection = Detection()
    contact: Contact = Contact()
    timing: Timing = Timing()
    rest: Rest = Rest()
    sensors: Sensors = Sensors()
    # policy (or strategy) name -> parameter overrides: numbers, flags, names, or lists of them
    policy_params: dict[Name, dict[Name, ParamValue]] = {}
    pre_impact: tuple[Name, ...] | None = (
        None  # pins the strategies swept for this scenario (names checked in world.check_scenario)
    )
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0

    @model_validator(mode="after")
    def _rates(self) -> Scenario:
        if self.physics_dt > self.control_dt:
            raise FieldProblem(
                "physics_dt",
                f"physics_dt ({self.physics_dt} s) must not exceed control_dt ({self.control_dt} s)",
            )
        ratio = self.control_dt / self.physics_dt
        if abs(ratio - round(ratio)) > 1e-9:
            raise FieldProblem(
                "control_dt", f"control_dt ({self.control_dt} s) must be a multiple of physics_dt"
            )
        for key in ("time_constant", "stop_time_constant"):
            if getattr(self.contact, key) < 2 * self.physics_dt:  # MuJoCo would stiffen it silently
                raise FieldProblem(
                    "physics_dt",
                    f"2 physics steps ({2 * self.physics_dt:g} s) exceed contact.{key} "
                    f"({getattr(self.contact, key)} s); lower physics_dt or raise contact.{key}",
                )
        if self.rest.hold < self.physics_dt:
            raise FieldProblem(
                "rest.hold",
                f"rest.hold ({self.rest.hold} s) is shorter than one physics step ({self.physics_dt} s)",
            )
        steps = self.duration / self.physics_dt
        if steps > MAX_STEPS_PER_RUN:
            raise FieldProblem(
                "duration",
                f"duration / physics_dt = {steps:,.0f} physics steps, over the budget of "
                f"{MAX_STEPS_PER_RUN:,} per run",
            )
        return self

    @property
    def physics_steps_per_control(self) -> int:
        return round(self.control_dt / self.physics_dt)


class ScenarioFile(Scenario):
    """A scenario file: a base scenario plus sweep, randomisation and seed repetition."""

    randomize: dict[
        Name, tuple[Annotated[float, Field(ge=-1e6, le=1e6)], Annotated[float, Field(ge=-1e6, le=1e6)]]
    ] = {}
    sweep: dict[Name, Annotated[list[Any], Field(max_length=MAX_POINTS_PER_FILE)]] = {}
    seeds: Annotated[int, Field(ge=1, le=MAX_POINTS_PER_FILE)] = 1
    layout_yaw: Degrees = (
        0.0  # deg: turns every obstacle about the world z axis through the origin (the robot)
    )
    sizes_for: Name | None = (
        None  # robot (name or card) the push forces and obstacle geometry are written for (scaled on others)
    )
    per_robot: dict[
        Name, dict[Name, Any]
    ] = {}  # robot (name or card) -> dotted key -> value, after the scaling


ScenarioError = InputError  # bad scenario input (or a bad robot card it names): one line, exit 2
UNION_TAGS = ("box", "cylinder")  # the obstacle types: pydantic puts them into an error's location


def resolved_params(kind: str, name: str, defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """A policy's or strategy's parameters: its defaults overridden by the scenario's (no unknown ones)."""
    unknown = set(given) - set(defaults)
    if unknown:
        raise ValueError(
            f"{kind} {name!r}: unknown parameter(s) {', '.join(sorted(unknown))}; "
            f"known: {', '.join(sorted(defaults)) or 'none'}"
        )
    return {**defaults, **given}
