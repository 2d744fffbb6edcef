"""A robot card whose model is an MJCF (`model.mjcf`) rather than a URDF.

The MJCF is G1's URDF compiled by MuJoCo alone and saved as MJCF next to a link to G1's meshes
(`meshdir="meshes"`), with what a model collection's file carries besides the robot: a free joint on
the root, a floor, a light, actuators (the knees' torque limits on motors' ctrlrange, the elbows' on
position servos' forcerange, not on the joints), a sensor on a site named as the scene's IMU site,
a keyframe and a contact exclude. Its card is G1's with `model: {mjcf: g1.xml}`: the same robot, so
that the scene, the check and a drop can be compared with G1's from its URDF.
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.robots import ROBOTS, get_robot
from fallbench.robots.card import load_card
from fallbench.scenario import Scenario
from fallbench.sim.scene import build_spec
from fallbench.yamlfile import InputError

G1 = get_robot("g1")
MOVED_LIMITS = {"knee": "motor", "elbow": "position"}  # joint -> the kind of actuator carrying its limit
EXCLUDED = ("left_wrist_roll_link", "left_wrist_yaw_link")  # one of G1's disabled pairs, in the file


def _add_actuators(spec: mujoco.MjSpec) -> None:
    """A motor on each knee and a position servo on each elbow, holding their torque limits."""
    for joint in spec.joints:
        kind = next((k for part, k in MOVED_LIMITS.items() if part in joint.name), None)
        if kind is None:
            continue
        actuator = spec.add_actuator()
        actuator.name, actuator.target, actuator.trntype = joint.name, joint.name, mujoco.mjtTrn.mjTRN_JOINT
        if kind == "motor":
            actuator.ctrlrange, actuator.ctrllimited = joint.actfrcrange, mujoco.mjtLimited.mjLIMITED_TRUE
        else:
            actuator.set_to_position(kp=50)
            actuator.forcerange, actuator.forcelimited = joint.actfrcrange, mujoco.mjtLimited.mjLIMITED_TRUE
        joint.actfrcrange = [0.0, 0.0]


def _add_scene_parts(spec: mujoco.MjSpec, free_joint: bool) -> None:
    """A floor, a light, a site `imu` with a sensor, an exclude and a keyframe `stand` (G1's default)."""
    floor = spec.worldbody.add_geom()
    floor.name, floor.type, floor.size = "ground", mujoco.mjtGeom.mjGEOM_PLANE, [5.0, 5.0, 0.1]
    spec.worldbody.add_light().pos = [0.0, 0.0, 3.0]
    spec.body(G1.torso_body).add_site().name = "imu"
    sensor = spec.add_sensor()
    sensor.name, sensor.type = "imu_acc", mujoco.mjtSensor.mjSENS_ACCELEROMETER
    sensor.objtype, sensor.objname = mujoco.mjtObj.mjOBJ_SITE, "imu"
    exclude = spec.add_exclude()
    exclude.bodyname1, exclude.bodyname2 = EXCLUDED
    model = spec.compile()
    qpos = model.qpos0.copy()
    if free_joint:
        qpos[2] = G1.standing_height
    for name, value in G1.postures["default"].items():
        qpos[model.jnt_qposadr[model.joint(name).id]] = value
    key = spec.add_key()
    key.name, key.qpos = "stand", qpos.tolist()


def g1_mjcf(folder: Path, free_joint: bool = True) -> Path:
    """G1 as an MJCF in `folder` (g1.xml, meshes/ a link to G1's) and its card g1_mjcf.yaml, whose
    path this returns. `free_joint`: the file's root body carries one."""
    assert G1.urdf_path is not None
    folder.mkdir(parents=True, exist_ok=True)
    urdf = G1.urdf_text().replace(
        "</robot>",
        '<mujoco><compiler strippath="false" discardvisual="false" fusestatic="false" '
        'balanceinertia="true"/></mujoco></robot>',
    )
    spec = mujoco.MjSpec.from_string(urdf)  # visual geoms kept: the scene must drop them
    if free_joint:
        spec.body(G1.root_body).add_freejoint()
    (folder / "meshes").symlink_to(G1.urdf_path.parent.parent / "meshes")
    spec.meshdir, spec.modelfiledir = "meshes", f"{folder}/"
    for mesh in spec.meshes:
        mesh.file = Path(mesh.file).name
    _add_actuators(spec)
    _add_scene_parts(spec, free_joint)
    spec.compiler.savecompiled = spec.compiler.savecanonical = False  # authored values, full precision
    (folder / "g1.xml").write_text(spec.to_xml())
    card = re.sub(r"^model:\n(?:  .*\n)+", "model: {mjcf: g1.xml}\n", ROBOTS["g1"].read_text(), flags=re.M)
    card = card.replace("name: g1", "name: g1_mjcf").replace(f"  - [{', '.join(EXCLUDED)}]\n", "")
    (folder / "g1_mjcf.yaml").write_text(card)
    return folder / "g1_mjcf.yaml"


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


def test_an_mjcf_card_reads_the_robot_from_the_file(tmp_path: Path) -> None:
    robot = load_card(g1_mjcf(tmp_path))
    assert robot.mjcf_path == tmp_path / "g1.xml" and robot.urdf_path is None and robot.model_kind == "MJCF"
    assert robot.mass == pytest.approx(G1.mass, rel=1e-12)  # MuJoCo's, from the file's inertials
    stand = robot.postures["stand"]  # the file's keyframe: every hinge
    assert len(stand) == 29 and stand == {joint: G1.postures["default"].get(joint, 0.0) for joint in stand}
    assert robot.posture_base_height["stand"] == G1.standing_height  # the key's root height
    assert robot.disabled_collisions == G1.disabled_collisions  # the file's exclude, then the card's
    assert robot.armature == G1.armature and robot.body_groups == G1.body_groups


def test_the_scene_of_an_mjcf_is_the_scene_of_the_urdf(tmp_path: Path) -> None:
    """What the file adds to the robot is gone (actuators, sensor, keyframe, floor, visual geoms),
    the torque limits moved onto the joints: the compiled scene's physics is G1's, array by array."""
    card = str(g1_mjcf(tmp_path))
    urdf = build_spec(Scenario(name="s", duration=1.0, robot="g1")).compile()
    spec = build_spec(Scenario(name="s", duration=1.0, robot=card))
    mjcf = spec.compile()
    assert (mjcf.nu, mjcf.nkey, mjcf.ngeom, mjcf.nsensor) == (urdf.nu, 0, urdf.ngeom, urdf.nsensor)
    assert mjcf.nsite == urdf.nsite + 1  # the file's site `imu`, renamed
    assert mjcf.site("imu_mjcf").bodyid[0] == mjcf.body(G1.torso_body).id
    compared = 0
    for prefix in ("body_", "jnt_", "dof_", "geom_", "actuator_", "exclude_", "mesh_vert", "opt"):
        for name in (n for n in dir(urdf) if n.startswith(prefix) and n != "mesh_pathadr"):
            a, b = getattr(urdf, name), getattr(mjcf, name)
            if isinstance(a, np.ndarray):
                np.testing.assert_array_equal(a, b, err_msg=name)
                compared += 1
    assert compared > 100
    for attribute in ("timestep", "integrator", "cone", "disableflags", "gravity", "iterations"):
        np.testing.assert_array_equal(getattr(urdf.opt, attribute), getattr(mjcf.opt, attribute))
    exported = invoke("scenarios", "export", str(_drop(tmp_path, card)), "--out", str(tmp_path / "s.xml"))
    assert exported.exit_code == 0, exported.output
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "s.xml")).nmesh == urdf.nmesh  # absolute meshdir


@pytest.mark.parametrize("free_joint", [True, False], ids=["free joint", "no free joint"])
def test_robots_check_passes_an_mjcf_card_with_pinocchio_from_the_file(tmp_path: Path, free_joint) -> None:
    result = invoke("robots", "check", str(g1_mjcf(tmp_path, free_joint)))
    assert result.exit_code == 0 and "ok: " in result.output, result.output
    assert "mass: 33.34 kg in the MJCF, 33.34 kg simulated" in result.output
    assert re.search(r"left_knee_joint +\[-0\.087, \+2\.880\] +139\.0", result.output)  # the motor's limit
    assert re.search(
        r"Pinocchio \(from g1\.xml\) vs MuJoCo \(relative\): mass matrix \S+e-1[5-9]", result.output
    )
    assert (
        "root 0.757 -> 0.755 m" in result.output and "touching in the default stance: none" in result.output
    )


def _drop(folder: Path, robot: str) -> Path:
    path = folder / f"drop_{Path(robot).stem}.yaml"
    path.write_text(f"name: drop\nrobot: {robot}\ninitial: {{posture: default, height: 0.5}}\n")
    return path


@pytest.mark.slow
def test_an_mjcf_drop_is_stored_and_equals_the_urdf_drop(tmp_path: Path, sweep) -> None:
    """Under the fixed-gain policies (no Pinocchio in the loop) every metric is G1's from its URDF,
    to the last bit."""
    from fallbench.results.store import load_metrics

    card = str(g1_mjcf(tmp_path / "robot"))
    tables = {}
    for robot in ("g1", card):
        ran = sweep(_drop(tmp_path, robot), tmp_path / Path(robot).stem, policies="stiff,zero")
        assert ran.exit_code == 0 and len(ran.simulated) == 2, ran.output
        tables[robot] = load_metrics(tmp_path / Path(robot).stem).set_index("policy").sort_index()
    mjcf, urdf = tables[card], tables["g1"]
    assert (mjcf.status == "ok").all() and set(mjcf.robot) == {card}
    identity = {"run_id", "robot", "point", "group", "source"} | {c for c in urdf if c.startswith("version:")}
    timings = {c for c in urdf if "wall" in c or "_ms_" in c or c.endswith("_ms")}
    compared = [c for c in urdf.columns if c not in identity | timings]
    assert len(compared) > 100
    for column in compared:
        assert mjcf[column].equals(urdf[column]), column


@pytest.mark.parametrize(
    "edit, key, reason",
    [
        (lambda c: c.replace("model: {mjcf: g1.xml}", "model: {}"), "model", "either `urdf` or `mjcf`"),
        (
            lambda c: c.replace("model: {mjcf: g1.xml}", "model: {mjcf: g1.xml, urdf: g1.xml}"),
            "model",
            "either `urdf` or `mjcf`, one of the two",
        ),
        (
            lambda c: c.replace("{mjcf: g1.xml}", "{mjcf: broken.xml}"),
            "model.mjcf",
            "MuJoCo cannot read broken.xml",
        ),
        (lambda c: c.replace("{mjcf: g1.xml}", "{mjcf: two.xml}"), "model.mjcf", "worldbody holds 2 bodies"),
        (
            lambda c: c.replace("root_body: pelvis", "root_body: torso_link"),
            "root_body",
            "not g1.xml's top body",
        ),
        (
            lambda c: (
                c + "inertia_overrides: {head_link: {ixx: 1, ixy: 0, ixz: 0, iyy: 1, iyz: 0, izz: 1}}\n"
            ),
            "inertia_overrides",
            "in an MJCF, fix the body's <inertial>",
        ),
        (
            lambda c: c.replace("{mjcf: g1.xml}", "{mjcf: two_joints.xml}"),
            "model.mjcf",
            "has several joints (left_elbow_joint and more): Pinocchio merges them",
        ),
    ],
    ids=["neither", "both", "not MJCF", "two robots", "root not on top", "inertia override", "two joints"],
)
def test_a_bad_mjcf_card_is_one_line_at_its_key(tmp_path: Path, edit, key: str, reason: str) -> None:
    card = g1_mjcf(tmp_path)
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><body name='a'></mujoco>")
    two = (tmp_path / "g1.xml").read_text().replace("<worldbody>", "<worldbody><body name='box'/>")
    (tmp_path / "two.xml").write_text(two)
    elbow = re.search(r'<joint name="left_elbow_joint"[^>]*/>', two)
    assert elbow is not None
    twist = '<joint name="left_elbow_twist" axis="1 0 0"/>'
    keyless = re.sub(r"<keyframe>.*</keyframe>", "", (tmp_path / "g1.xml").read_text(), flags=re.S)
    (tmp_path / "two_joints.xml").write_text(keyless.replace(elbow[0], elbow[0] + twist))
    card.write_text(edit(card.read_text()))
    result = invoke("robots", "show", str(card))
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    line = next(
        i + 1 for i, text in enumerate(card.read_text().splitlines()) if text.startswith(key.split(".")[0])
    )
    assert result.output.startswith(f"error: {card}:{line}: {key}: ") and reason in result.output, (
        result.output
    )
    with pytest.raises(InputError):
        load_card(card)
