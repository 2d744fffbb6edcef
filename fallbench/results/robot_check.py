"""`fallbench robots check`: can a robot run the benchmark? Its card compiled, measured and compared.

The report says what the card and the model give (mass, standing height, actuated joints with
their limits, the bodies each body group matched) and runs the checks the benchmark relies on,
each with the reason it fails:

- every actuated joint has a range and a torque limit (the URDF's `limit` lower/upper and effort,
  an MJCF's joint range and actuatorfrcrange or actuator limits): the knee margin and the torque
  metrics read them, the servo is clamped at the torque limit;
- the feet have collision geometry (contacts are sensed on bodies with geometry alone);
- no two robot bodies touch in the `default` stance (such a pair belongs in `disabled_collisions`);
- standing in `default` under `stiff` for `STAND_TIME` s, the robot neither falls nor drifts, comes
  to rest upright, at the card's `standing_height`, on bodies of its `feet` body group alone (the
  group `adaptive_qp_hold` tells a landing by);
- Pinocchio's mass matrix and nonlinear effects (the QP methods' model, which Pinocchio builds from
  the same URDF or MJCF) equal MuJoCo's at random states, after the joint map.

The robot tests (tests/test_physics.py, tests/test_model_agreement.py) run these same functions
on every shipped card.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from fallbench.assembly import simulate_named
from fallbench.dynamics.model import PinocchioModel, build_pinocchio
from fallbench.robots import get_robot
from fallbench.robots.description import RobotDescription
from fallbench.robots.meshes import converted_meshes
from fallbench.scenario import Scenario
from fallbench.sim.events import tilt_deg
from fallbench.sim.scene import FLOOR_NAME, stance_contacts
from fallbench.sim.settle import STAND_TIME, ensure_standing_height, stance_scenario, standing_height_file
from fallbench.sim.world import World, build_world, initial_state

MAX_DRIFT = 0.05  # m of base drift in the ground plane while standing
HEIGHT_TOLERANCE = 0.01  # m between the settled root height and the card's `standing_height`
REST_WINDOW = 0.1  # s at the end over which every speed must be small
MAX_REST_SPEED = 0.2  # rad/s and m/s, every velocity coordinate over `REST_WINDOW`
MAX_TILT = 5.0  # deg of the torso from upright at the end (TALOS settles 3 deg forward)
MASS_MATRIX_TOLERANCE = 1e-9  # of the largest entry (or 1): Pinocchio's M against MuJoCo's
BIAS_TOLERANCE = 1e-8  # of the largest entry (or 1): Pinocchio's nonlinear effects against MuJoCo's
AGREEMENT_SEEDS = 3  # random states compared


@dataclass(frozen=True)
class Standing:
    """The robot after standing `STAND_TIME` s in `default` under `stiff`."""

    status: str  # the run's status (ok, diverged, error)
    duration: float  # s simulated
    fell: bool  # a fall was detected
    drift: float  # m, base drift in the ground plane
    start_height: float  # m, root height at t = 0
    end_height: float  # m, root height at the end
    end_speed: float  # rad/s or m/s, the largest velocity coordinate over the last REST_WINDOW s
    tilt: float  # deg of the torso from upright at the end
    floor_bodies: tuple[str, ...] = ()  # robot bodies touching the floor at the end

    @property
    def sag(self) -> float:
        """m the root went down while standing."""
        return self.start_height - self.end_height

    def problems(self, standing_height: float) -> list[str]:
        """Why this is not standing still at `standing_height` (m), if it is not."""
        found = []
        if self.status != "ok" or self.fell:
            found.append(f"does not stand under stiff (status {self.status}, fall detected: {self.fell})")
        if self.drift >= MAX_DRIFT:
            found.append(f"drifts {self.drift * 1000:.0f} mm standing (limit {MAX_DRIFT * 1000:.0f} mm)")
        if abs(self.end_height - standing_height) >= HEIGHT_TOLERANCE:
            found.append(
                f"stands at {self.end_height:.3f} m, the card says standing_height {standing_height:.3f} m"
            )
        if self.end_speed >= MAX_REST_SPEED:
            found.append(f"still moves after {STAND_TIME:g} s ({self.end_speed:.2f} rad/s or m/s)")
        if self.tilt >= MAX_TILT:
            found.append(f"leans {self.tilt:.1f} deg standing (limit {MAX_TILT:g} deg)")
        return found

    def feet_problems(self, feet: tuple[str, ...]) -> list[str]:
        """Why the `feet` body group is not what the robot stands on: `adaptive_qp_hold` hands a
        first impact to its QP only when every body touching is in it (a landing on the feet)."""
        if not self.floor_bodies:
            return []  # not standing: problems() says so
        why = "adaptive_qp_hold hands only a landing on the feet to its QP"
        if not set(self.floor_bodies) & set(feet):
            return [
                f"no body of body_groups.feet touches the floor standing in default (it stands on "
                f"{', '.join(self.floor_bodies)}): {why}, so it would hand none"
            ]
        return [
            f"{body} touches the floor standing in default but is not in body_groups.feet: {why}, "
            "so it would take a landing on it for an impact elsewhere"
            for body in self.floor_bodies
            if body not in feet
        ]


def floor_bodies(world: World, qpos: np.ndarray) -> tuple[str, ...]:
    """The robot bodies whose geometry touches the floor at `qpos`, in body order."""
    model = world.model
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    floor = model.geom(FLOOR_NAME).id
    bodies = {
        int(model.geom_bodyid[c.geom2 if c.geom1 == floor else c.geom1])
        for c in data.contact[: data.ncon]
        if floor in (c.geom1, c.geom2)
    }
    return tuple(model.body(body).name for body in sorted(bodies))


def stand(robot: str) -> Standing:
    """Stand the robot for `STAND_TIME` s in `default` under `stiff` and measure it."""
    scenario = stance_scenario(robot)
    rec = simulate_named(scenario, "stiff")
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, rec.qpos[-1, 3:7])
    tail = max(round(REST_WINDOW / scenario.physics_dt), 1)
    return Standing(
        status=rec.status,
        duration=float(rec.time[-1]),
        fell=rec.fall_time is not None,
        drift=float(np.linalg.norm(rec.qpos[-1, :2] - rec.qpos[0, :2])),
        start_height=float(rec.qpos[0, 2]),
        end_height=float(rec.qpos[-1, 2]),
        end_speed=float(np.abs(rec.qvel[-tail:]).max()),
        tilt=float(tilt_deg(rotation.reshape(3, 3))),
        floor_bodies=floor_bodies(rec.world, rec.qpos[-1]),
    )


def touching_pairs(world: World, scenario: Scenario) -> list[tuple[str, str]]:
    """Pairs of robot bodies in contact at the start of `scenario` (the floor left out)."""
    model = world.model
    data = initial_state(world, scenario)
    mujoco.mj_collision(model, data)
    pairs = []
    for contact in data.contact[: data.ncon]:
        bodies = (int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2]))
        if 0 not in bodies:
            pairs.append((model.body(bodies[0]).name, model.body(bodies[1]).name))
    return sorted(set(pairs))


def random_state(robot: str, seed: int) -> tuple[World, mujoco.MjData]:
    """The robot in the air (root 0.3 m up) at a random orientation, joint offsets and velocity."""
    scenario = Scenario(name="t", duration=1.0, robot=robot, initial={"height": 0.3})
    world = build_world(scenario)
    data = initial_state(world, scenario)
    rng = np.random.default_rng(seed)
    quat = rng.normal(size=4)
    data.qpos[3:7] = quat / np.linalg.norm(quat)
    data.qpos[world.qpos_adr] += rng.uniform(-0.2, 0.2, size=len(world.qpos_adr))
    data.qvel[:] = rng.normal(size=world.model.nv)
    mujoco.mj_forward(world.model, data)
    return world, data


def _velocity_map(data: mujoco.MjData, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """T with v_mujoco = T v_pin (base linear velocity world <- base frame), and its rate term."""
    rotation = data.xmat[1].reshape(3, 3)
    T = np.eye(nv)
    T[:3, :3] = rotation
    v_local = rotation.T @ data.qvel[:3]
    T_dot_v = np.zeros(nv)
    T_dot_v[:3] = rotation @ np.cross(data.qvel[3:6], v_local)
    return T, T_dot_v


def _pin_to_mj_order(P: PinocchioModel, nv: int) -> np.ndarray:
    """Permutation: MuJoCo velocity index of each Pinocchio velocity index."""
    order = np.empty(nv, dtype=int)
    order[:6] = np.arange(6)
    order[6:] = P.mj_to_pin_v
    return order


@dataclass(frozen=True)
class Agreement:
    """Largest differences between Pinocchio's and MuJoCo's terms, relative to the largest entry (or 1)."""

    mass_matrix: float
    bias: float  # nonlinear effects: Coriolis, centrifugal and gravity forces

    def problems(self) -> list[str]:
        found = []
        if not self.mass_matrix < MASS_MATRIX_TOLERANCE:
            found.append(
                f"Pinocchio's mass matrix differs from MuJoCo's by {self.mass_matrix:.1e} (relative)"
            )
        if not self.bias < BIAS_TOLERANCE:
            found.append(f"Pinocchio's nonlinear effects differ from MuJoCo's by {self.bias:.1e} (relative)")
        return found


def agreement(robot: str, seeds: int = AGREEMENT_SEEDS) -> Agreement:
    """Pinocchio's M and h against MuJoCo's at `seeds` random states, in Pinocchio's velocity
    coordinates: M = T' M_mj T, h = T' (bias_mj + M_mj T_dot v)."""
    mass_matrix, bias = 0.0, 0.0
    for seed in range(seeds):
        world, data = random_state(robot, seed)
        model = world.model
        P = build_pinocchio(world)
        q, v = P.state(data.qpos, data.qvel)
        M_pin = pin.crba(P.model, P.data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        nle_pin = pin.nonLinearEffects(P.model, P.data, q, v)
        M_mj = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M_mj)
        T, T_dot_v = _velocity_map(data, model.nv)
        order = _pin_to_mj_order(P, model.nv)
        M_mj_in_pin = (T.T @ M_mj @ T)[np.ix_(order, order)]
        nle_mj_in_pin = (T.T @ (data.qfrc_bias + M_mj @ T_dot_v))[order]
        mass_matrix = max(mass_matrix, np.abs(M_pin - M_mj_in_pin).max() / max(1.0, np.abs(M_mj).max()))
        bias = max(bias, np.abs(nle_pin - nle_mj_in_pin).max() / max(1.0, np.abs(data.qfrc_bias).max()))
    return Agreement(float(mass_matrix), float(bias))


# Where a model file gives a joint's range and torque limit, for the messages
LIMIT_SOURCES = {
    "URDF": ("the URDF's limit lower/upper", "the URDF's limit effort"),
    "MJCF": (
        "the MJCF's joint range",
        "the MJCF's actuatorfrcrange, or an actuator's forcerange or motor ctrlrange",
    ),
}


def joint_problems(world: World) -> list[str]:
    """Actuated joints without a range or a torque limit, or no actuated joint at all."""
    model = world.model
    kind = world.robot.model_kind
    if not world.joint_names:
        return [f"no actuated joint (no revolute or hinge joint in the {kind})"]
    found = []
    for index, name in enumerate(world.joint_names):
        if not model.jnt_limited[model.joint(name).id]:
            found.append(f"joint {name} has no range ({LIMIT_SOURCES[kind][0]})")
        if world.torque_limit[index] <= 0:
            found.append(f"joint {name} has no torque limit ({LIMIT_SOURCES[kind][1]})")
    return found


def sensed_bodies(world: World, bodies: tuple[str, ...]) -> tuple[str, ...]:
    """The bodies that have collision geometry (contacts are sensed on those alone)."""
    return tuple(body for body in bodies if world.model.body_geomnum[world.model.body(body).id] > 0)


@dataclass(frozen=True)
class RobotReport:
    lines: tuple[str, ...]  # what the check found, for people
    problems: tuple[str, ...]  # why the robot cannot run the benchmark; empty when it can


def _joint_lines(world: World) -> list[str]:
    lines = [f"actuated joints: {len(world.joint_names)} (range rad, torque limit Nm, kp Nm/rad, kd Nms/rad)"]
    for index, name in enumerate(world.joint_names):
        low, high = world.joint_range[index]
        lines.append(
            f"  {name:<32} [{low:+.3f}, {high:+.3f}]  {world.torque_limit[index]:7.1f}  "
            f"{world.default_kp[index]:7.1f}  {world.default_kd[index]:6.2f}"
        )
    return lines


def _group_lines(world: World) -> tuple[list[str], list[str]]:
    """Lines of what each body group matched; a problem when the feet have no collision geometry."""
    lines, problems = ["body groups (bodies with collision geometry, whose contacts are sensed):"], []
    for group, bodies in world.robot.body_groups.items():
        sensed = sensed_bodies(world, bodies)
        lines.append(f"  {group}: {len(bodies)} bodies, {len(sensed)} sensed: {', '.join(bodies) or '-'}")
    if not sensed_bodies(world, world.robot.body_groups["feet"]):
        problems.append("no body of the feet has collision geometry: the robot cannot stand on them")
    for part, bodies in world.robot.vulnerable_parts.items():
        lines.append(f"  vulnerable part {part}: {', '.join(bodies)}")
    return lines, problems


def _contact_lines(world: World, scenario: Scenario) -> tuple[list[str], list[str]]:
    """The robot bodies touching in the stance, each pair a problem."""
    touching = touching_pairs(world, scenario)
    lines = [
        "robot bodies touching in the default stance: "
        + (", ".join(f"{a}-{b}" for a, b in touching) or "none")
    ]
    if world.robot.disable_stance_contacts:
        auto = stance_contacts(world.robot)
        lines.insert(
            0,
            "collision pairs disabled as touching in the default stance (disabled_collisions: auto): "
            + (", ".join(f"{a}-{b}" for a, b in auto) or "none"),
        )
    return lines, [
        f"{a} and {b} touch in the default stance: add the pair to disabled_collisions" for a, b in touching
    ]


def _motion_lines(robot: str) -> tuple[list[str], list[str]]:
    """Standing under `stiff`, and Pinocchio against MuJoCo."""
    standing, terms = stand(robot), agreement(robot)
    description = get_robot(robot)
    height = description.standing_height
    source = "card" if description.standing_height_given else "derived"
    lines = [
        f"standing in default under stiff for {standing.duration:.2f} s: status {standing.status}, "
        f"root {standing.start_height:.3f} -> {standing.end_height:.3f} m (sag {standing.sag * 1000:.1f} mm; "
        f"{source} standing_height {height:.3f} m), drift {standing.drift * 1000:.1f} mm, "
        f"tilt {standing.tilt:.1f} deg, last speeds up to {standing.end_speed:.3f}",
        f"standing on: {', '.join(standing.floor_bodies) or 'nothing'} "
        f"(body_groups.feet: {', '.join(description.body_groups['feet'])})",
        f"Pinocchio (from {description.model_path.name}) vs MuJoCo (relative): mass matrix "
        f"{terms.mass_matrix:.1e}, nonlinear effects {terms.bias:.1e}",
    ]
    feet = standing.feet_problems(description.body_groups["feet"])
    return lines, standing.problems(height) + feet + terms.problems()


def mesh_lines(description: RobotDescription) -> list[str]:
    """Which of the robot's meshes were converted for MuJoCo (COLLADA to STL), and from where."""
    converted = list({mesh.source: mesh for mesh in converted_meshes(description)}.values())  # once per file
    if not converted:
        return [f"meshes: none converted (MuJoCo reads the {description.model_kind}'s meshes as they are)"]
    cached = sum(mesh.cached for mesh in converted)
    lines = [f"meshes: {len(converted)} COLLADA files converted to STL ({cached} from the cache):"]
    return lines + [f"  {mesh.source} -> {mesh.target}" for mesh in converted]


def check_robot(robot: str) -> RobotReport:
    """Compile the robot (a shipped name or a card path), report it, and run the checks."""
    description = get_robot(robot)
    scenario = stance_scenario(robot)
    world = build_world(scenario)
    lines = [
        f"robot {description.name}: card {description.card_path}",
        f"model: {description.model_path} ({description.version})",
        standing_height_line(robot),
        f"mass: {description.mass:.2f} kg in the {description.model_kind}, "
        f"{world.model.body_subtreemass[world.root_body]:.2f} kg simulated",
        *mesh_lines(description),
        *_joint_lines(world),
    ]
    problems = joint_problems(world)
    for more_lines, more_problems in (_group_lines(world), _contact_lines(world, scenario)):
        lines += more_lines
        problems += more_problems
    if joint_problems(world):  # e.g. a continuous joint: neither the servo's stop nor Pinocchio's map fit it
        lines.append(
            "standing and the model agreement not checked: the joints need a range and a torque limit"
        )
    else:
        motion_lines, motion_problems = _motion_lines(robot)
        lines += motion_lines
        problems += motion_problems
    return RobotReport(tuple(lines), tuple(problems))


def standing_height_line(robot: str) -> str:
    """Where the robot's standing height comes from: its card, or derived (now if not cached)."""
    description = get_robot(robot)
    if description.standing_height_given:
        return f"standing height: {description.standing_height:.3f} m, given by the card"
    height = ensure_standing_height(robot)
    return (
        f"standing height: {height:.3f} m, derived (the card gives none): the root's height after "
        f"{STAND_TIME:g} s standing in default under stiff, cached in {standing_height_file(robot)}"
    )


def describe(robot: str) -> list[str]:
    """What a robot's card gives, with the names its patterns matched (no simulation)."""
    r = get_robot(robot)
    lines = [
        f"robot {r.name}: card {r.card_path}",
        f"model: {r.model_path}" + (f", {r.srdf_path}" if r.srdf_path else "") + f" ({r.version})",
        f"fingerprint (card and model files): {r.fingerprint}",
        f"mass {r.mass:.2f} kg, standing height "
        + (
            f"{r.standing_height:.3f} m"
            if r.standing_height_known
            else "not given (derived when checked or run)"
        ),
        f"bodies: root {r.root_body}, torso {r.torso_body}, IMU {r.imu_body}"
        + ("" if r.imu_pose is None else f" at {list(r.imu_pose[0])} m, quaternion {list(r.imu_pose[1])}"),
        f"postures: {', '.join(r.postures)}",
        "stiff gains (Nm/rad, Nms/rad): "
        + ", ".join(f"{g.pattern} {g.kp:g}/{g.kd:g}" for g in r.gain_groups),
        "learned-policy gains: "
        + (", ".join(f"{g.pattern} {g.kp:g}/{g.kd:g}" for g in r.learned_gain_groups) or "none"),
        f"armature: {len(r.armature)} joints, disabled collision pairs: {len(r.disabled_collisions)}"
        + (" and those touching in the default stance (auto)" if r.disable_stance_contacts else ""),
    ]
    lines += [f"body group {group}: {', '.join(bodies) or '-'}" for group, bodies in r.body_groups.items()]
    lines += [f"leg {side}: {', '.join(joints)}" for side, joints in r.legs.items()]
    lines += [
        f"arm {side}: shoulder {a.shoulder_joint}, elbow {a.elbow_joint}, wrist {a.wrist_joint} on {a.wrist_frame}, "
        f"wrist pitch {a.wrist_pitch_joint}, hand {a.hand_frame}"
        for side, a in r.arms.items()
    ] or ["arms: none"]
    lines.append(f"feet: {', '.join(f'{side} {body}' for side, body in r.feet.items()) or 'none'}")
    return lines
