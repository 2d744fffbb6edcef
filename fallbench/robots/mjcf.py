"""A robot given as an MJCF (MuJoCo's XML): what a card may name in it, the robot alone as the
scene builds on it, and the Pinocchio model of the same file.

A card's `model.mjcf` points at a MuJoCo model of the robot, as model collections ship them: often
with a free joint on the root body, a floor, lights, actuators, sensors, its own keyframes and
contact excludes. `read_mjcf` compiles the file with MuJoCo and gives what the card loader checks
the card against, as `read_urdf` does for a URDF: the bodies and joints (every hinge is an actuated
joint), the named <key>s as postures with the root's height in them, the contact excludes as
disabled collision pairs, the joints' armature and the mass (MuJoCo's: an MJCF's masses may come
from its geoms).

`robot_spec` is the robot as the scene takes it (fallbench/sim/scene.py), so that it behaves as the
same robot read from a URDF:

- kept from the file: the robot's bodies, inertials, joints (ranges, damping, friction loss,
  stiffness), collision geoms and meshes, tendons and equality constraints, the compiler settings
  that read the file (angle unit, inertia from geoms, mesh folder, made absolute);
- moved: each hinge's torque limit onto the joint (`actuatorfrcrange`, else the forcerange of an
  actuator on it, else the ctrlrange of a motor on it times its gear), where the servo's clamp
  reads it; the keyframes (postures) and excludes (disabled pairs) are in the card's description,
  which the scene applies;
- removed: the actuators (fallbench's servo drives every hinge: two would drive it twice), sensors,
  keyframes, explicit contact pairs, the free joint of the root (the scene adds its own), the
  worldbody's geoms and lights (the floor is the scene's), the purely visual geoms (as a URDF's
  visuals are discarded), gravity compensation; a site named as the scene's IMU site is renamed;
- replaced by MuJoCo's defaults, then by the scene's: the <option>s (step, integrator, solver,
  gravity), the memory size, the contact parameters of every geom (margin, gap, priority, solmix
  here; contype, conaffinity, condim, friction, solref, solimp in the scene), the limit softness
  of every joint, and the file's top-level <default>s for what the scene adds (floor, servos,
  sensors, the root's free joint).

`pinocchio_model` is Pinocchio's model of the same file on a free-flyer root, the QP methods' model;
`pinocchio_problem` says why it would not map onto MuJoCo's by joint name (a body with several
joints, which Pinocchio merges into one composite joint).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco

if TYPE_CHECKING:
    import pinocchio as pin

JOINT_KINDS = {
    mujoco.mjtJoint.mjJNT_FREE: "free",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
}
SCENE_SITES = ("imu",)  # site names the scene adds: a file's site of that name is renamed `<name>_mjcf`
# What the scene adds takes these from MuJoCo's defaults, not from the file's top-level <default>
RESET_DEFAULTS = {
    "geom": (
        "contype conaffinity condim priority friction solmix solref solimp margin gap group rgba density"
    ),
    "joint": (
        "damping armature frictionloss stiffness springref margin solref_limit solimp_limit "
        "solref_friction solimp_friction actfrclimited actfrcrange group ref limited range"
    ),
    "actuator": (
        "gear gainprm biasprm dynprm gaintype biastype dyntype ctrllimited ctrlrange forcelimited "
        "forcerange actlimited actrange actdim actearly cranklength lengthrange group"
    ),
    "site": "size type group rgba",
}
RESET_GEOM = ("margin", "gap", "priority", "solmix")  # each robot geom's, to MuJoCo's defaults
RESET_JOINT = ("margin", "solimp_limit")  # each joint's (the scene sets solref_limit)


class MjcfError(ValueError):
    """The file cannot be read as a robot; the message is one line."""


@dataclass(frozen=True)
class MjcfModel:
    """What a card may name in an MJCF and what the loader derives from it."""

    links: tuple[str, ...]  # the named bodies of the robot (the top body's subtree), in file order
    joints: dict[str, str]  # name -> kind (hinge, slide, ball, free), in file order
    top_bodies: tuple[str, ...]  # the bodies directly in the worldbody
    postures: dict[str, dict[str, float]]  # named <key> -> hinge joint -> rad
    heights: dict[str, float]  # named <key> -> m, its root height (free joint's z)
    excludes: tuple[tuple[str, str], ...]  # <contact><exclude> body pairs
    armature: dict[str, float]  # hinge -> kg m^2, where the file gives one
    mass: float  # kg, the robot's, as MuJoCo compiles it


def load_spec(path: Path) -> mujoco.MjSpec:
    """The file parsed into an MjSpec; MjcfError when MuJoCo cannot parse it."""
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise MjcfError(f"MuJoCo cannot read {path.name}: {' '.join(str(exc).split())}") from None
    spec.compiler.fusestatic = False  # every body stays, as in a URDF: a card may name it
    return spec


def keyframe_postures(
    model: mujoco.MjModel, actuated: set[str]
) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """Named keyframes of a compiled model: posture name -> the values of its hinges that are in
    `actuated` (rad), and the height of its free joint where it has one (m). Unnamed keys are left
    out; a key that sets no actuated joint has an empty posture."""
    postures, heights = {}, {}
    for key in range(model.nkey):
        name = model.key(key).name
        if not name:
            continue
        qpos = model.key_qpos[key]
        joints = {}
        for joint in range(model.njnt):
            address = model.jnt_qposadr[joint]
            if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_FREE:
                heights[name] = float(qpos[address + 2])
            elif model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_HINGE and model.joint(joint).name in actuated:
                joints[model.joint(joint).name] = float(qpos[address])
        postures[name] = joints
    return postures, heights


def read_mjcf(path: Path) -> MjcfModel:
    """The robot of an MJCF file as MuJoCo compiles it; MjcfError (one line) when it cannot."""
    spec = load_spec(path)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise MjcfError(f"MuJoCo cannot compile {path.name}: {' '.join(str(exc).split())}") from None
    top = tuple(model.body(b).name for b in range(1, model.nbody) if model.body_parentid[b] == 0)
    robot = next((b for b in range(1, model.nbody) if model.body_parentid[b] == 0), 0)
    links = tuple(
        model.body(b).name
        for b in range(1, model.nbody)
        if model.body_rootid[b] == robot and model.body(b).name
    )
    joints: dict[str, str] = {}
    for joint in range(model.njnt):
        name, kind = model.joint(joint).name, JOINT_KINDS[mujoco.mjtJoint(model.jnt_type[joint])]
        if not name and kind == "hinge":
            body = model.body(model.jnt_bodyid[joint]).name
            raise MjcfError(f"{path.name}: a hinge of body {body!r} has no name, which its servo needs")
        if name:
            joints[name] = kind
    hinges = {name for name, kind in joints.items() if kind == "hinge"}
    postures, heights = keyframe_postures(model, hinges)
    armature = {
        model.joint(j).name: float(model.dof_armature[model.jnt_dofadr[j]])
        for j in range(model.njnt)
        if model.joint(j).name in hinges and model.dof_armature[model.jnt_dofadr[j]] > 0
    }
    return MjcfModel(
        links=links,
        joints=joints,
        top_bodies=top,
        postures={name: joints for name, joints in postures.items() if joints},
        heights=heights,
        excludes=tuple((e.bodyname1, e.bodyname2) for e in spec.excludes),
        armature=armature,
        mass=float(model.body_subtreemass[robot]) if robot else 0.0,
    )


def _torque_limit(spec: mujoco.MjSpec, joint: mujoco.MjsJoint) -> float:
    """Nm, a hinge's torque limit as the file gives it: its `actuatorfrcrange`, else the forcerange
    of an actuator on it, else the ctrlrange of a motor on it (fixed gain, no bias) times its gain
    and gear, the larger magnitude of the range's ends; 0 when the file gives none."""
    if (
        joint.actfrclimited != mujoco.mjtLimited.mjLIMITED_FALSE
        and joint.actfrcrange[1] > joint.actfrcrange[0]
    ):
        return float(max(-joint.actfrcrange[0], joint.actfrcrange[1]))
    for actuator in spec.actuators:
        if actuator.trntype != mujoco.mjtTrn.mjTRN_JOINT or actuator.target != joint.name:
            continue
        low, high = actuator.forcerange
        if actuator.forcelimited != mujoco.mjtLimited.mjLIMITED_FALSE and high > low:
            return float(max(-low, high))
        motor = (
            actuator.gaintype == mujoco.mjtGain.mjGAIN_FIXED
            and actuator.biastype == mujoco.mjtBias.mjBIAS_NONE
            and actuator.dyntype == mujoco.mjtDyn.mjDYN_NONE
        )
        low, high = actuator.ctrlrange
        if motor and actuator.ctrllimited != mujoco.mjtLimited.mjLIMITED_FALSE and high > low:
            return float(max(-low, high) * abs(actuator.gear[0] * actuator.gainprm[0]))
    return 0.0


def _move_torque_limits(spec: mujoco.MjSpec) -> None:
    """Each hinge's torque limit onto the joint (`actfrcrange`, read by the scene's servo)."""
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        limit = _torque_limit(spec, joint)
        joint.actfrcrange = [-limit, limit]
        joint.actfrclimited = (
            mujoco.mjtLimited.mjLIMITED_TRUE if limit > 0 else mujoco.mjtLimited.mjLIMITED_FALSE
        )


def _reset_defaults(spec: mujoco.MjSpec, pristine: mujoco.MjSpec) -> None:
    """The file's options, memory size and top-level <default>s replaced by MuJoCo's own (those of
    `pristine`, an empty spec), for what the scene sets and adds."""
    spec.option = pristine.option
    for size in ("memory", "nconmax", "njmax", "nstack"):
        setattr(spec, size, getattr(pristine, size))
    for kind, names in RESET_DEFAULTS.items():
        target, source = getattr(spec.default, kind), getattr(pristine.default, kind)
        for name in names.split():
            setattr(target, name, getattr(source, name))
    spec.compiler.alignfree = False  # the root's free joint at the body's frame, as for a URDF


def _remove_scene_parts(spec: mujoco.MjSpec, root_body: str) -> None:
    """The actuators, sensors, keyframes, contact pairs and excludes; the worldbody's geoms and
    lights; the root's free joint."""
    world = spec.worldbody
    parts = [*spec.actuators, *spec.sensors, *spec.keys, *spec.pairs, *spec.excludes]
    parts += [*world.geoms, *world.lights]
    parts += [j for j in spec.body(root_body).joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    for part in parts:
        spec.delete(part)


def robot_spec(path: Path, root_body: str) -> mujoco.MjSpec:
    """The robot of an MJCF as the scene builds on it (this module's docstring says what changes)."""
    spec = load_spec(path)
    folder = path.resolve().parent
    for key in ("meshdir", "texturedir"):  # absolute, so that an exported scene finds the files too
        setattr(spec, key, str(folder / getattr(spec, key)) if getattr(spec, key) else str(folder))
    pristine = mujoco.MjSpec()
    _reset_defaults(spec, pristine)
    _move_torque_limits(spec)
    _remove_scene_parts(spec, root_body)
    for body in spec.bodies:
        body.gravcomp = 0.0
    for site in spec.sites:
        if site.name in SCENE_SITES:
            site.name = f"{site.name}_mjcf"
    spec.discard_visual()
    geom_default, joint_default = pristine.default.geom, pristine.default.joint
    for geom in spec.geoms:
        for name in RESET_GEOM:
            setattr(geom, name, getattr(geom_default, name))
    for joint in spec.joints:
        for name in RESET_JOINT:
            setattr(joint, name, getattr(joint_default, name))
    return spec


def pinocchio_model(path: Path) -> pin.Model:
    """Pinocchio's model of the file with a free-flyer root: the file's free joint where it has one,
    else a free flyer `root` the robot is appended to (Pinocchio 4.1's MJCF reader with a root
    joint checks the file's own qpos0 against the model and refuses a file without a free joint)."""
    import pinocchio as pin

    model = pin.buildModelFromMJCF(str(path))
    if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer":
        return model
    base = pin.Model()
    root = base.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    frame = base.addJointFrame(root)
    return pin.appendModel(base, model, frame, pin.SE3.Identity())


def pinocchio_problem(path: Path, joints: dict[str, str]) -> str | None:
    """Why Pinocchio's model of the file does not map onto MuJoCo's `joints` (name -> kind, as
    `read_mjcf` gives them) by joint name, else None."""
    try:
        model = pinocchio_model(path)
    except (RuntimeError, ValueError) as exc:
        return f"Pinocchio cannot read {path.name}: {' '.join(str(exc).split())}"
    names = list(model.names)
    merged = [name for j, name in enumerate(names) if model.joints[j].shortname().endswith("Composite")]
    if merged:
        return (
            f"a body of {path.name} has several joints ({merged[0].removeprefix('Composite_')} and more): "
            "Pinocchio merges them into one, which fallbench's joint map does not follow; "
            "give each joint a body of its own"
        )
    if set(names[2:]) != {name for name, kind in joints.items() if kind != "free"}:
        return f"Pinocchio reads other joints from {path.name} than MuJoCo does"
    return None
