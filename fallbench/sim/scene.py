"""The MuJoCo scene of one scenario, uncompiled (an `MjSpec`): robot, floor, obstacles, IMU,
contact sensors, servo actuators. Compiling it, and the compiled models' caches, are world.py's.

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

import math

import mujoco

from fallbench.robots import get_robot
from fallbench.robots.description import DEFAULT_POSTURE, RobotDescription
from fallbench.robots.meshes import mujoco_urdf_text
from fallbench.robots.mjcf import robot_spec
from fallbench.scenario import Box, Contact, Cylinder, Scenario

IMPEDANCE_SHAPE = (0.5, 2.0)  # solimp midpoint and power: MuJoCo's defaults
ROBOT_COLLISION_BITS = (1, 1)  # contype, conaffinity: robot geoms touch each other and the scene
FLOOR_NAME = "floor"
OBSTACLE_PREFIX = "obstacle_"  # geom of obstacle i: obstacle_<i>


def _robot_spec(robot: RobotDescription) -> mujoco.MjSpec:
    """The robot alone, from its URDF (what MuJoCo's URDF reader makes of it) or its MJCF
    (fallbench/robots/mjcf.py says what is kept and what the scene replaces)."""
    import xml.etree.ElementTree as ET

    if robot.mjcf_path is not None:
        return robot_spec(robot.mjcf_path, robot.root_body)
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
