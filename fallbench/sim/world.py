"""A compiled scene (`World`: the MuJoCo model and the indices the controller, recorder and metrics
need), its caches in memory and on disk, the state at t = 0, the checks that need the scene, and
its export as MJCF. What the scene holds, and its contact parameters, are scene.py's.
"""

from __future__ import annotations

import copy
import dataclasses
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
from fallbench.robots.description import RobotDescription
from fallbench.scenario import DEFAULT_PHYSICS_DT, Scenario
from fallbench.sim import scene
from fallbench.sim.scene import OBSTACLE_PREFIX, build_spec

POSTURE_NOISE_STREAM = 1  # random stream of the posture noise, apart from the seed's randomised keys


@dataclass(frozen=True)
class SensorSlice:
    start: int
    size: int


@dataclass
class World:
    """A compiled scene and the indices the controller, recorder and metrics need. A run's own
    (`build_world`: its model a copy of the cached scene's), or the cached scene (`scene_world`)."""

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
    contact_found_index: slice | np.ndarray  # those columns as an index of the sensor rows (`found_columns`)

    def sensor(self, sensordata: np.ndarray, name: str) -> np.ndarray:
        s = self.sensors[name]
        return sensordata[..., s.start : s.start + s.size]


def found_columns(columns: np.ndarray) -> slice | np.ndarray:
    """The contact sensors' "found" columns of the sensor rows (`World.contact_found_columns`), as a
    slice when evenly spaced (the sensors follow one another): a view of the rows, where a list of
    columns copies them."""
    if len(columns) < 2:
        return columns
    stride = int(columns[1] - columns[0])
    if stride <= 0 or not np.array_equal(columns, np.arange(columns[0], columns[-1] + 1, stride)):
        return columns
    return slice(int(columns[0]), int(columns[-1]) + 1, stride)


# ---------------------------------------------------------------- compiled world
#
# Ownership: the cache (`_SCENES`, one `World` per scene, at most `SCENES_KEPT`) owns the compiled
# models, which nothing writes. A run owns the `World` `build_world` gives it: a copy of the cached
# model (`copy.copy`: 2 ms for TALOS, 30-35 ms for G1, where loading takes 10-40 ms and compiling
# 70-450 ms) with the scenario's friction and step, into which the run's servo writes its gains, and
# its own `MjData` (`initial_state`). The checks and exports that only read a scene use the cached
# `World` itself (`scene_world`).

# Scenario keys MuJoCo reads at run time, set on a run's model rather than compiled in, so that
# randomised friction (a Gymnasium environment draws one per episode) does not make a model per draw
RUNTIME_KEYS = {"friction": Scenario.model_fields["friction"].default, "physics_dt": DEFAULT_PHYSICS_DT}
SCENES_KEPT = 8  # compiled scenes kept in memory per process (a worker sees few; G1's model is 34 MB)
MODEL_CACHE_FILES = 32  # compiled models kept on disk (G1's is 33 MB): the least recently written go
_SCENES: dict[str, World] = {}  # scene key -> the scene compiled at the run-time keys' defaults


def scene_key(scenario: Scenario) -> str:
    """Only what changes the compiled model: a sweep over pushes, heights, friction or the physics
    step reuses one model (the run-time keys are set on each run's copy of it)."""
    return scenario.model_copy(
        update={
            "initial": None,
            "push": None,
            "duration": 1.0,
            "seed": 0,
            "name": "",
            "detection": None,
            "policy_params": {},
            **RUNTIME_KEYS,
        }
    ).model_dump_json()


@cache
def _builder_source() -> bytes:
    """This module's, the scene's and the robot layer's source: what turns a scenario into a model."""
    robots = sorted((Path(__file__).parent.parent / "robots").rglob("*.py"))
    files = [Path(__file__), Path(scene.__file__), *robots]
    return b"".join(path.read_bytes() for path in files)


def _set_runtime(model: mujoco.MjModel, scenario: Scenario) -> None:
    """The scenario's friction on every geom (the robot's and the scene's, as `_soften` sets it) and
    its step: the model a compile of `scenario` itself gives, byte for byte (tests/test_startup.py)."""
    model.geom_friction[:, 0] = scenario.friction
    model.opt.timestep = scenario.physics_dt


def scene_digest(scenario: Scenario) -> str:
    """What the compiled scene of `scenario` is made of, hashed: its scene key, MuJoCo's and the
    robot description's versions, the robot's card and model files (its fingerprint) and the
    source that builds the model. The compiled worlds' cache key, and that of what is derived from
    them (a standing height the card leaves out, sim/settle.py)."""
    robot = get_robot(scenario.robot)
    digest = hashlib.sha256(
        scene_key(scenario).encode()
        + mujoco.__version__.encode()
        + robot.version.encode()
        + robot.fingerprint.encode()
        + _builder_source()
    )
    return digest.hexdigest()[:16]


def _model_cache_file(scenario: Scenario) -> Path:
    robot = get_robot(scenario.robot)
    return cache_root() / f"world-{robot.name}-{scene_digest(scenario)}.mjb"


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


def _load_model(template: Scenario) -> mujoco.MjModel:
    """The compiled model of `template` (a scenario at the run-time keys' defaults), from the disk
    cache when an identical one was compiled before (MuJoCo's binary format: loading takes 10-40 ms
    where compiling takes 70 ms for TALOS, 450 ms for G1), so every worker and every command does
    not compile the robot again. The file's key holds everything that builds the model: the scene
    key, MuJoCo's and the description's versions, the robot's card and model files (its
    fingerprint) and the source of this module, of scene.py and of the robot layer."""
    path = _model_cache_file(template)
    if path.exists():
        try:
            return mujoco.MjModel.from_binary_path(str(path))
        except ValueError:  # unreadable (e.g. truncated by a full disk): compile and replace it
            pass
    model = build_spec(template).compile()
    _save_to_cache(model, path)
    return model


def _index(model: mujoco.MjModel, robot: RobotDescription) -> World:
    """The world of a compiled model: its actuated joints, sensors and body groups."""
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
    found = np.array([sensors[n].start for n in body_sensors])
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
        contact_found_columns=found,
        contact_found_index=found_columns(found),
    )


def scene_world(scenario: Scenario) -> World:
    """The cached compiled scene of `scenario`, shared by every run of it in this process, at the
    run-time keys' defaults (not the scenario's friction and step): to read, never to write or to
    step. A run uses `build_world`."""
    key = scene_key(scenario)
    world = _SCENES.get(key)
    if world is None:
        template = scenario.model_copy(update=RUNTIME_KEYS)
        if len(_SCENES) >= SCENES_KEPT:
            _SCENES.pop(next(iter(_SCENES)))
        world = _SCENES[key] = _index(_load_model(template), get_robot(scenario.robot))
    return world


def compile_model(scenario: Scenario) -> mujoco.MjModel:
    """A model of the scenario's own: a copy of the cached scene's with its friction and step."""
    model = copy.copy(scene_world(scenario).model)
    _set_runtime(model, scenario)
    return model


def build_world(scenario: Scenario) -> World:
    """The world of one run: the cached scene's indices and a model of the run's own
    (`compile_model`), which its servo and its rollouts may write."""
    return dataclasses.replace(scene_world(scenario), model=compile_model(scenario))


# ---------------------------------------------------------------- initial state


LEVEL_SOLES = 1e-6  # m: soles whose lowest points differ by less are level (float32 mesh vertices)
BOX_CORNERS = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T  # a unit box's, (8, 3)


def _lowest_point(model: mujoco.MjModel, data: mujoco.MjData, body_ids: set[int]) -> float:
    """Lowest z of the robot's collision geometry (box corners and mesh vertices)."""
    lowest = math.inf
    geom_body, geom_type = model.geom_bodyid.tolist(), model.geom_type.tolist()  # read once, not per geom
    for g in range(model.ngeom):
        if geom_body[g] not in body_ids:
            continue
        rot, pos = data.geom_xmat[g].reshape(3, 3), data.geom_xpos[g]
        if geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            corners = BOX_CORNERS * model.geom_size[g]
        elif geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
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
    world = scene_world(scenario)
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
    world = scene_world(scenario)
    data = initial_state(world, scenario)
    spec = build_spec(scenario)
    key = spec.add_key()
    key.name = "start"
    key.qpos = data.qpos.tolist()
    key.ctrl = data.ctrl.tolist()
    spec.compile()
    return spec.to_xml()
