"""The MuJoCo scene of one scenario: robot, floor, obstacles, IMU, contact sensors, servo actuators.

Contact and joint-limit softness decide the impact peaks; they are the scenario's `contact:`
parameters (stated defaults), applied to every robot, floor and obstacle geom alike:

- integrator `implicitfast`, physics step from the scenario (0.5 ms by default: 25 steps per
  contact time constant, where halving the step moves the landing IMU peak by under 4 %);
- contacts: solref (0.0125 s, 1.0), a critically damped contact with a 12.5 ms time constant
  (MuJoCo asks for >= 2 steps per time constant; the schema enforces it), solimp
  (0.9, 0.95, 0.001); condim 3 with the scenario's friction;
- joint limits (mechanical stops): solreflimit (0.005 s, 1.0), a 5 ms stop, so that a joint
  driven into its stop is stopped within a few milliseconds as by a hard end stop;
- self-collisions on, except the pairs the robot's card (or its SRDF) disables and parent-child pairs;
- MuJoCo's automatic reset on divergence is disabled, so a diverged run is seen and stored.
"""

from __future__ import annotations

import copy
import hashlib
import math
import os
import tempfile
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import mujoco
import numpy as np

from fallbench.robots import get_robot, robot_problem
from fallbench.robots.cache import cache_root
from fallbench.robots.description import DEFAULT_POSTURE, RobotDescription
from fallbench.robots.meshes import mujoco_urdf_text
from fallbench.scenario import DEFAULT_PHYSICS_DT, Box, Contact, Cylinder, Scenario

IMPEDANCE_SHAPE = (0.5, 2.0)  # solimp midpoint and power: MuJoCo's defaults
ROBOT_COLLISION_BITS = (1, 1)  # contype, conaffinity: robot geoms touch each other and the scene
FLOOR_NAME = "floor"
OBSTACLE_PREFIX = "obstacle_"  # geom of obstacle i: obstacle_<i>
POSTURE_NOISE_STREAM = 1  # random stream of the posture noise, apart from the seed's randomised keys


@dataclass(frozen=True)
class SensorSlice:
    start: int
    size: int


@dataclass
class World:
    """A compiled scene and the indices the controller, recorder and metrics need."""

    model: mujoco.MjModel
    robot: RobotDescription
    joint_names: tuple[str, ...]  # actuated joints, in actuator order
    qpos_adr: np.ndarray  # qpos index of each actuated joint
    qvel_adr: np.ndarray  # qvel index of each actuated joint
    torque_limit: np.ndarray  # Nm, per actuator
    joint_range: np.ndarray  # rad, (n, 2)
    default_kp: np.ndarray  # Nm/rad
    default_kd: np.ndarray  # Nms/rad
    sensors: dict[str, SensorSlice]
    contact_groups: dict[str, list[str]]  # body group -> contact sensor names
    obstacle_sensors: list[str]
    torso_body: int
    root_body: int
    contact_bodies: list[str]  # body of each per-body contact sensor
    contact_found_columns: np.ndarray  # sensordata column of each one's "found" count

    def sensor(self, sensordata: np.ndarray, name: str) -> np.ndarray:
        s = self.sensors[name]
        return sensordata[..., s.start : s.start + s.size]


# ---------------------------------------------------------------- building the spec


def _robot_spec(robot: RobotDescription) -> mujoco.MjSpec:
    import xml.etree.ElementTree as ET

    tree = ET.fromstring(mujoco_urdf_text(robot))  # COLLADA meshes as STL
    for tag in ("gazebo", "transmission"):
        for element in tree.findall(tag):
            tree.remove(element)
    extension = ET.SubElement(tree, "mujoco")
    # strippath=false: two different meshes are both called base_link.STL.
    ET.SubElement(
        extension,
        "compiler",
        strippath="false",
        discardvisual="true",
        fusestatic="false",
        balanceinertia="true",
    )
    return mujoco.MjSpec.from_string(ET.tostring(tree, encoding="unicode"))


def _soften(geom: mujoco.MjsGeom, scenario: Scenario) -> None:
    """Friction, and the contact softness of `scenario.contact` (solref, solimp)."""
    contact = scenario.contact
    geom.friction = [scenario.friction, 0.005, 0.0001]
    geom.solref = (contact.time_constant, contact.damping_ratio)
    geom.solimp = (*contact.impedance, *IMPEDANCE_SHAPE)


def obstacle_geoms(model: mujoco.MjModel) -> list[int]:
    """Ids of the scenario's obstacle geoms in a compiled world."""
    return [g for g in range(model.ngeom) if model.geom(g).name.startswith(OBSTACLE_PREFIX)]


def _add_obstacle(spec: mujoco.MjSpec, index: int, obstacle: Box | Cylinder, scenario: Scenario) -> None:
    geom = spec.worldbody.add_geom()
    geom.name = f"{OBSTACLE_PREFIX}{index}"
    geom.pos = obstacle.pos
    if isinstance(obstacle, Box):
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [s / 2 for s in obstacle.size]
        half_yaw = math.radians(obstacle.yaw) / 2
        geom.quat = [math.cos(half_yaw), 0.0, 0.0, math.sin(half_yaw)]
    else:
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        geom.size = [obstacle.radius, obstacle.height / 2, 0.0]
    _soften(geom, scenario)
    geom.rgba = [0.6, 0.45, 0.3, 1.0]


def _add_contact_sensor(
    spec: mujoco.MjSpec, name: str, body: str, subtree: bool = False, geom2: str | None = None
) -> None:
    """Net force between `body` (or its subtree) and the environment: the world's static geoms
    (floor and obstacles), or one obstacle geom. Robot self-contacts are not counted."""
    sensor = spec.add_sensor()
    sensor.name = name
    sensor.type = mujoco.mjtSensor.mjSENS_CONTACT
    sensor.objtype = mujoco.mjtObj.mjOBJ_XBODY if subtree else mujoco.mjtObj.mjOBJ_BODY
    sensor.objname = body
    sensor.reftype = mujoco.mjtObj.mjOBJ_BODY if geom2 is None else mujoco.mjtObj.mjOBJ_GEOM
    sensor.refname = "world" if geom2 is None else geom2
    # data = found (1) + force (3), reduced to the net force over all matching contacts
    sensor.intprm = [1 | 2, 3, 1] + [0] * (len(sensor.intprm) - 3)


def _set_options(spec: mujoco.MjSpec, scenario: Scenario) -> None:
    """Name, step and solver options; no automatic reset, so that a diverged run is seen and stored."""
    spec.modelname = f"fallbench_{scenario.name}"
    spec.option.timestep = scenario.physics_dt
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL


def _set_robot_contacts(spec: mujoco.MjSpec, robot: RobotDescription, scenario: Scenario) -> None:
    """Every robot geom collides with the scene and the robot, with the scenario's contact softness,
    except the body pairs the robot's card (or its SRDF) disables, and with `disabled_collisions:
    auto` those touching in the `default` stance."""
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = ROBOT_COLLISION_BITS
        geom.condim = 3
        _soften(geom, scenario)
    _exclude(spec, robot.disabled_collisions)
    if robot.disable_stance_contacts:
        _exclude(spec, stance_contacts(robot))


def _exclude(spec: mujoco.MjSpec, pairs: tuple[tuple[str, str], ...]) -> None:
    for body1, body2 in pairs:
        if spec.body(body1) is not None and spec.body(body2) is not None:
            exclude = spec.add_exclude()
            exclude.bodyname1, exclude.bodyname2 = body1, body2


_STANCE_CONTACTS: dict[tuple[str, str], tuple[tuple[str, str], ...]] = {}


def stance_contacts(robot: RobotDescription) -> tuple[tuple[str, str], ...]:
    """Pairs of the robot's bodies whose collision geometry touches in the `default` stance, the
    disabled pairs left out: what `disabled_collisions: auto` disables. The robot alone, compiled
    as the world compiles it, posed in `default` (once per robot and card in a process)."""
    key = (str(robot.card_path), robot.fingerprint)
    if key not in _STANCE_CONTACTS:
        spec = _robot_spec(robot)
        spec.body(robot.root_body).add_freejoint()
        for geom in spec.geoms:
            geom.contype, geom.conaffinity = ROBOT_COLLISION_BITS
        _exclude(spec, robot.disabled_collisions)
        model = spec.compile()
        data = mujoco.MjData(model)
        for name, value in robot.postures[DEFAULT_POSTURE].items():
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_forward(model, data)
        bodies = (
            (int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2]))
            for c in data.contact[: data.ncon]
        )
        pairs = {tuple(sorted((model.body(a).name, model.body(b).name))) for a, b in bodies if a and b}
        _STANCE_CONTACTS[key] = tuple(sorted(pairs))
    return _STANCE_CONTACTS[key]


def _add_scene(spec: mujoco.MjSpec, scenario: Scenario) -> None:
    """The floor, the scenario's obstacles and a light above."""
    floor = spec.worldbody.add_geom()
    floor.name = FLOOR_NAME
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [20.0, 20.0, 0.1]
    _soften(floor, scenario)
    floor.rgba = [0.8, 0.8, 0.8, 1.0]
    for index, obstacle in enumerate(scenario.obstacles):
        _add_obstacle(spec, index, obstacle, scenario)
    light = spec.worldbody.add_light()
    light.pos, light.dir = [0.0, 0.0, 4.0], [0.0, 0.0, -1.0]


def _add_servos(spec: mujoco.MjSpec, robot: RobotDescription, contact: Contact) -> None:
    """A position servo with the robot's default gains on each hinge, its torque clamped to the
    joint's limit (Nm); each hinge's armature and its limit stop (`contact.stop_*`, default 5 ms)."""
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        joint.armature = robot.armature.get(joint.name, 0.0)
        joint.solref_limit = (contact.stop_time_constant, contact.stop_damping_ratio)
        kp, kd = robot.default_gains(joint.name)
        actuator = spec.add_actuator()
        actuator.name = joint.name
        actuator.target = joint.name
        actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
        actuator.set_to_position(kp=kp, kv=kd)
        limit = joint.actfrcrange[1]
        if limit > 0:  # else no effort in the URDF: unclamped (`fallbench robots check` says so)
            actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            actuator.forcerange = [-limit, limit]
        else:
            actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _add_sensors(
    spec: mujoco.MjSpec, kinds: tuple[tuple[str, mujoco.mjtSensor], ...], objtype: mujoco.mjtObj, objname: str
) -> None:
    """One sensor per (name, kind) of `kinds`, all on the same object."""
    for name, kind in kinds:
        sensor = spec.add_sensor()
        sensor.name, sensor.type = name, kind
        sensor.objtype, sensor.objname = objtype, objname


def _add_state_sensors(spec: mujoco.MjSpec, robot: RobotDescription) -> None:
    """IMU (accelerometer, gyro), the root body's pose and velocity, the whole robot's CoM."""
    imu = spec.body(robot.imu_body).add_site()
    imu.name = "imu"
    if robot.imu_pose is not None:  # a card's `imu_site`
        imu.pos, imu.quat = robot.imu_pose
    _add_sensors(
        spec,
        (("imu_acc", mujoco.mjtSensor.mjSENS_ACCELEROMETER), ("imu_gyro", mujoco.mjtSensor.mjSENS_GYRO)),
        mujoco.mjtObj.mjOBJ_SITE,
        "imu",
    )
    # XBODY: the body's own frame (BODY would be its inertial frame, which a URDF may rotate)
    _add_sensors(
        spec,
        (
            ("base_pos", mujoco.mjtSensor.mjSENS_FRAMEPOS),
            ("base_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT),
            ("base_linvel", mujoco.mjtSensor.mjSENS_FRAMELINVEL),
        ),
        mujoco.mjtObj.mjOBJ_XBODY,
        robot.root_body,
    )
    # whole-robot CoM and its velocity, for the capture point (computed in C inside the step)
    _add_sensors(
        spec,
        (("com_pos", mujoco.mjtSensor.mjSENS_SUBTREECOM), ("com_vel", mujoco.mjtSensor.mjSENS_SUBTREELINVEL)),
        mujoco.mjtObj.mjOBJ_BODY,
        robot.root_body,
    )


def _add_contact_sensors(spec: mujoco.MjSpec, robot: RobotDescription, obstacles: int) -> None:
    """The whole robot against the world, each body of the robot's body groups that has geoms,
    and the whole robot against each of the `obstacles` obstacles."""
    _add_contact_sensor(spec, "contact:total", robot.root_body, subtree=True)
    for group, bodies in robot.body_groups.items():
        for body in bodies:
            if spec.body(body) is not None and spec.body(body).geoms:
                _add_contact_sensor(spec, f"contact:{group}:{body}", body)
    for index in range(obstacles):
        _add_contact_sensor(
            spec, f"obstacle:{index}", robot.root_body, subtree=True, geom2=f"{OBSTACLE_PREFIX}{index}"
        )


def build_spec(scenario: Scenario) -> mujoco.MjSpec:
    """The scenario's scene, uncompiled: robot on a free joint, floor and obstacles, servos, sensors."""
    robot = get_robot(scenario.robot)
    spec = _robot_spec(robot)
    _set_options(spec, scenario)
    spec.body(robot.root_body).add_freejoint().name = "root"
    _set_robot_contacts(spec, robot, scenario)
    _add_scene(spec, scenario)
    _add_servos(spec, robot, scenario.contact)
    _add_state_sensors(spec, robot)
    _add_contact_sensors(spec, robot, len(scenario.obstacles))
    return spec


# ---------------------------------------------------------------- compiled world


def _world_key(scenario: Scenario) -> str:
    """Only what changes the compiled model: a sweep over pushes or heights reuses one model."""
    return scenario.model_copy(
        update={
            "initial": None,
            "push": None,
            "duration": 1.0,
            "seed": 0,
            "name": "",
            "detection": None,
            "policy_params": {},
        }
    ).model_dump_json()


@cache
def _builder_source() -> bytes:
    """This module's and the robot layer's source: what turns a scenario into a model."""
    files = [Path(__file__), *sorted((Path(__file__).parent.parent / "robots").rglob("*.py"))]
    return b"".join(path.read_bytes() for path in files)


MODEL_CACHE_FILES = 32  # compiled models kept on disk (G1's is 33 MB): the least recently written go
TEMPLATES_KEPT = 4  # compiled models kept in memory per process, by cache file
_TEMPLATES: dict[Path, mujoco.MjModel] = {}
# Scenario keys MuJoCo reads at run time, set on the loaded model rather than compiled in, so that
# randomised friction (a Gymnasium environment draws one per episode) does not make a model per draw
RUNTIME_KEYS = {"friction": Scenario.model_fields["friction"].default, "physics_dt": DEFAULT_PHYSICS_DT}


def _set_runtime(model: mujoco.MjModel, scenario: Scenario) -> None:
    """The scenario's friction on every geom (the robot's and the scene's, as `_soften` sets it) and
    its step: the model a compile of `scenario` itself gives, byte for byte (tests/test_startup.py)."""
    model.geom_friction[:, 0] = scenario.friction
    model.opt.timestep = scenario.physics_dt


def _model_cache_file(scenario: Scenario) -> Path:
    robot = get_robot(scenario.robot)
    digest = hashlib.sha256(
        _world_key(scenario).encode()
        + mujoco.__version__.encode()
        + robot.version.encode()
        + robot.fingerprint.encode()
        + _builder_source()
    )
    return cache_root() / f"world-{robot.name}-{digest.hexdigest()[:16]}.mjb"


def _save_to_cache(model: mujoco.MjModel, path: Path) -> None:
    """Write atomically, then drop the oldest files past `MODEL_CACHE_FILES`; a read-only or full
    cache only costs the next process a compile."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkstemp(dir=path.parent, suffix=".mjb.tmp")[1])
        mujoco.mj_saveModel(model, str(tmp), None)
        os.replace(tmp, path)
        files = sorted(path.parent.glob("world-*.mjb"), key=lambda f: f.stat().st_mtime_ns)
        for old in files[: max(len(files) - MODEL_CACHE_FILES, 0)]:
            old.unlink(missing_ok=True)
    except OSError:  # also a file another worker removed meanwhile
        if tmp is not None:
            tmp.unlink(missing_ok=True)


def compile_model(scenario: Scenario) -> mujoco.MjModel:
    """The scenario's compiled model, from the disk cache when an identical one was compiled
    before (MuJoCo's binary format: loading takes 10-40 ms where compiling takes 70 ms for TALOS,
    450 ms for G1), so every worker and every command does not compile the robot again. The key
    holds everything that builds the model but the run-time keys (`RUNTIME_KEYS`, set after
    loading): the world key, MuJoCo's and the description's versions, the robot's card and model
    files (its fingerprint) and the source of this module and of the robot layer."""
    template = scenario.model_copy(update=RUNTIME_KEYS)
    path = _model_cache_file(template)
    if path not in _TEMPLATES:
        model = None
        if path.exists():
            try:
                model = mujoco.MjModel.from_binary_path(str(path))
            except ValueError:  # unreadable (e.g. truncated by a full disk): compile and replace it
                pass
        if model is None:
            model = build_spec(template).compile()
            _save_to_cache(model, path)
        if len(_TEMPLATES) >= TEMPLATES_KEPT:
            _TEMPLATES.pop(next(iter(_TEMPLATES)))
        _TEMPLATES[path] = model
    model = copy.copy(_TEMPLATES[path])  # half the time of reading G1's file again
    _set_runtime(model, scenario)
    return model


def _compile(scenario: Scenario) -> World:
    model = compile_model(scenario)
    robot = get_robot(scenario.robot)
    sensors = {
        model.sensor(i).name: SensorSlice(int(model.sensor_adr[i]), int(model.sensor_dim[i]))
        for i in range(model.nsensor)
    }
    names = tuple(model.actuator(i).name for i in range(model.nu))
    joint_ids = [model.joint(n).id for n in names]
    groups: dict[str, list[str]] = {}
    for name in sensors:
        if name.startswith("contact:") and name != "contact:total":
            groups.setdefault(name.split(":")[1], []).append(name)
    body_sensors = [n for names in groups.values() for n in names]
    return World(
        model=model,
        robot=robot,
        joint_names=names,
        qpos_adr=np.array([model.jnt_qposadr[j] for j in joint_ids]),
        qvel_adr=np.array([model.jnt_dofadr[j] for j in joint_ids]),
        torque_limit=model.actuator_forcerange[:, 1].copy(),
        joint_range=model.jnt_range[joint_ids].copy(),
        default_kp=model.actuator_gainprm[:, 0].copy(),
        default_kd=-model.actuator_biasprm[:, 2].copy(),
        sensors=sensors,
        contact_groups=groups,
        obstacle_sensors=[n for n in sensors if n.startswith("obstacle:")],
        torso_body=model.body(robot.torso_body).id,
        root_body=model.body(robot.root_body).id,
        contact_bodies=[n.split(":")[2] for n in body_sensors],
        contact_found_columns=np.array([sensors[n].start for n in body_sensors]),
    )


_WORLDS: dict[str, World] = {}


def build_world(scenario: Scenario) -> World:
    """The compiled scene for a scenario; scenarios that differ only in start/push share it."""
    key = _world_key(scenario)
    if key not in _WORLDS:
        if len(_WORLDS) >= 8:  # a worker sees few distinct scenes; bound the memory anyway
            _WORLDS.pop(next(iter(_WORLDS)))
        _WORLDS[key] = _compile(scenario)
    return _WORLDS[key]


# ---------------------------------------------------------------- initial state


LEVEL_SOLES = 1e-6  # m: soles whose lowest points differ by less are level (float32 mesh vertices)


def _lowest_point(model: mujoco.MjModel, data: mujoco.MjData, body_ids: set[int]) -> float:
    """Lowest z of the robot's collision geometry (box corners and mesh vertices)."""
    lowest = math.inf
    for g in range(model.ngeom):
        if model.geom_bodyid[g] not in body_ids:
            continue
        rot, pos = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T * model.geom_size[g]
        elif model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            corners = model.mesh_vert[start : start + count]
        else:  # other primitives: their bounding sphere
            lowest = min(lowest, pos[2] - model.geom_rbound[g])
            continue
        lowest = min(lowest, float((corners @ rot.T + pos)[:, 2].min()))
    return lowest


def initial_state(world: World, scenario: Scenario) -> mujoco.MjData:
    """MjData at t = 0: the named posture with overrides, feet `initial.height` above the floor."""
    model, robot = world.model, world.robot
    data = mujoco.MjData(model)
    posture = dict(robot.postures[scenario.initial.posture])
    posture.update(scenario.initial.joints)
    for name, value in posture.items():
        joint = model.joint(name)
        data.qpos[model.jnt_qposadr[joint.id]] = value
    if scenario.initial.joint_noise > 0:  # posture noise, the same for every policy of a seed
        noise = np.random.default_rng([scenario.seed, POSTURE_NOISE_STREAM]).uniform(
            -1, 1, len(world.joint_names)
        )
        # The legs keep the posture: noise there tilts the soles (0.03 rad on each of six leg joints
        # leaves a sole's corners up to ~2 cm apart), so a standing start would rest on one corner,
        # drop, and be declared a fall at t = 0 with a foot's landing as the impact.
        noise[np.isin(world.joint_names, robot.leg_joints)] = 0.0
        noisy = data.qpos[world.qpos_adr] + scenario.initial.joint_noise * noise
        data.qpos[world.qpos_adr] = np.clip(noisy, world.joint_range[:, 0], world.joint_range[:, 1])
    root_adr = model.jnt_qposadr[model.body_jntadr[world.root_body]]
    data.qpos[root_adr : root_adr + 7] = [0, 0, 0, 1, 0, 0, 0]
    mujoco.mj_kinematics(model, data)
    robot_bodies = set(range(1, model.nbody))
    lowest = _lowest_point(model, data, robot_bodies)
    # Soles level to within their meshes' rounding all rest on the floor: Romeo's right sole is 1 nm
    # above its left one, and a start on one foot puts the capture point outside the support at t = 0
    soles = [_lowest_point(model, data, {model.body(foot).id}) for foot in robot.feet.values()]
    if soles and 0 < max(soles) - lowest < LEVEL_SOLES:
        lowest = max(soles)
    data.qpos[root_adr + 2] = scenario.initial.height - lowest
    data.ctrl[:] = data.qpos[world.qpos_adr]
    mujoco.mj_forward(model, data)
    return data


# ---------------------------------------------------------------- checks before running


def check_scene(scenario: Scenario) -> tuple[str, str] | None:
    """(key, reason) of the first problem that needs the robot or the scene to see, else None."""
    problem = robot_problem(scenario.robot)
    if problem:
        return "robot", problem
    robot = get_robot(scenario.robot)
    if scenario.initial.posture not in robot.postures:
        return (
            "initial.posture",
            f"unknown posture {scenario.initial.posture!r} (known: {', '.join(robot.postures)})",
        )
    world = build_world(scenario)
    model = world.model
    for name in scenario.initial.joints:
        if name not in world.joint_names:
            return f"initial.joints.{name}", f"unknown joint of robot {robot.name!r}"
    for name, value in scenario.initial.joints.items():
        low, high = world.joint_range[world.joint_names.index(name)]
        if not low <= value <= high:
            return (
                f"initial.joints.{name}",
                f"{value} rad is outside the joint range [{low:.3f}, {high:.3f}] rad",
            )
    if (
        scenario.push
        and scenario.push.body is not None
        and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, scenario.push.body) < 1
    ):
        return "push.body", f"unknown body {scenario.push.body!r} of robot {robot.name!r}"
    if scenario.push and scenario.push.start >= scenario.duration:
        return (
            "push.start",
            f"the push starts at {scenario.push.start} s, after the episode ends ({scenario.duration} s)",
        )
    if not scenario.obstacles:  # nothing to intersect (posing the robot costs each point ~4 ms)
        return None
    data = initial_state(world, scenario)
    mujoco.mj_collision(model, data)
    for contact in data.contact[: data.ncon]:
        names = {model.geom(contact.geom1).name, model.geom(contact.geom2).name}
        obstacle = next((n for n in names if n.startswith(OBSTACLE_PREFIX)), None)
        if obstacle is not None and contact.dist < 0:
            index = int(obstacle.removeprefix(OBSTACLE_PREFIX))
            return (
                f"obstacles.{index}",
                f"intersects the robot at start (penetration {-contact.dist * 1000:.0f} mm)",
            )
    return None


def export_mjcf(scenario: Scenario) -> str:
    """The scene as MJCF text, with the initial state as keyframe `start`."""
    world = build_world(scenario)
    data = initial_state(world, scenario)
    spec = build_spec(scenario)
    key = spec.add_key()
    key.name = "start"
    key.qpos = data.qpos.tolist()
    key.ctrl = data.ctrl.tolist()
    spec.compile()
    return spec.to_xml()
