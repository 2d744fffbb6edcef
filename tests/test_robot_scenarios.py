"""Scenarios on every robot: `robot` is sweepable, `--robot` overrides the files, sizes scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fallbench.checks import check_scenario, load
from fallbench.cli import SHIPPED, app
from fallbench.robots import ROBOTS, get_robot
from fallbench.scenario import Scenario, load_scenario_file
from fallbench.sim.support import body_box_corners
from fallbench.sim.world import build_world

ROOT = Path(__file__).resolve().parents[1]

SCALED = """name: s
robot: talos
sizes_for: talos
duration: 1.0
push: {force: 200, duration: 0.1, start: 0.1}
obstacles:
  - {type: box, pos: [1.0, 0.0, 0.25], size: [0.4, 0.4, 0.5]}
  - {type: cylinder, pos: [-1.0, 0.0, 0.5], radius: 0.1, height: 1.0}
sweep:
  robot: [talos, g1]
"""


def test_robot_sweep_scales_force_by_mass_and_obstacles_by_standing_height(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(SCALED)
    talos, g1 = load_scenario_file(path, check=check_scenario)
    assert (talos.scenario.robot, g1.scenario.robot) == ("talos", "g1")
    assert talos.scenario.push.force == 200 and talos.scenario.obstacles[0].pos == (1.0, 0.0, 0.25)
    mass = get_robot("g1").mass / get_robot("talos").mass
    length = get_robot("g1").standing_height / get_robot("talos").standing_height
    assert 0.36 < mass < 0.38 and 0.73 < length < 0.75  # 33.3 / 90.3 kg, 0.755 / 1.019 m
    assert g1.scenario.push.force == pytest.approx(200 * mass)
    box, post = g1.scenario.obstacles
    assert box.pos == pytest.approx((length, 0.0, 0.25 * length)) and box.size == pytest.approx(
        (0.4 * length,) * 2 + (0.5 * length,)
    )
    assert (post.radius, post.height) == pytest.approx((0.1 * length, length))
    assert g1.label == "s[robot=g1]#s0" and g1.swept["scale:force"] == pytest.approx(mass)


def test_per_robot_values_replace_the_scaled_ones(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(SCALED + "per_robot:\n  g1: {push.force: 90, initial.joints: {left_elbow_joint: 0.3}}\n")
    g1 = load_scenario_file(path, check=check_scenario)[1].scenario
    assert g1.push.force == 90 and g1.initial.joints == {"left_elbow_joint": 0.3}


def test_robot_option_overrides_every_file() -> None:
    points = load([ROOT / p for p in SHIPPED], robot="g1")
    assert points and {p.scenario.robot for p in points} == {"g1"}
    assert all(p.label.startswith(f"{p.scenario.name}[robot=g1") for p in points)
    drops = [p for p in points if p.scenario.name == "drop"]
    assert sorted({p.scenario.initial.height for p in drops}) == [
        0.25,
        0.5,
        0.75,
        1.0,
        1.25,
    ]  # heights are not scaled


@pytest.mark.parametrize(
    "text, key, reason",
    [
        (SCALED.replace("sizes_for: talos", "sizes_for: atlas"), "sizes_for", "unknown robot 'atlas'"),
        (SCALED + "per_robot:\n  g1: {push.colour: 1}\n", "push.colour", "unknown key"),
    ],
)
def test_bad_robot_keys_are_one_clear_line(tmp_path: Path, text: str, key: str, reason: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    result = CliRunner().invoke(app, ["scenarios", "validate", str(path)])
    assert result.exit_code == 2 and key in result.output and reason in result.output


def test_unknown_robot_option_exits_2(tmp_path: Path, sweep) -> None:
    result = sweep(None, tmp_path / "r", "--robot", "atlas")  # the shipped files
    assert result.exit_code == 2 and "--robot: unknown robot 'atlas'" in result.output
    assert not (tmp_path / "r").exists()


def test_every_robot_has_a_default_posture_and_declared_parts() -> None:
    for name in ROBOTS:
        robot = get_robot(name)
        assert "default" in robot.postures and robot.standing_height > 0
        assert set(robot.legs) == set(robot.arms) == {"left", "right"}
        assert set(robot.knee_joints) <= set(robot.leg_joints)
        assert set(robot.trajectory_joints) <= set(robot.timeseries_joints)
        assert set(robot.leg_pitch("right").values()) <= set(robot.timeseries_joints)
        assert robot.vulnerable_bodies and set(robot.vulnerable_bodies) <= set(robot.contact_candidates)


def test_point_selector_matches_the_robot(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app,
        [
            "scenarios",
            "export",
            str(ROOT / "scenarios/drop.yaml"),
            "--point",
            "robot=g1",
            "--point",
            "initial.height=0.5",
            "--point",
            "physics_dt=0.0005",
            "--out",
            str(tmp_path / "scene.xml"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert (
        "drop[robot=g1,initial.height=0.5,physics_dt=0.0005]#s0" in result.output
        and "pelvis" in (tmp_path / "scene.xml").read_text()
    )
    ambiguous = CliRunner().invoke(
        app, ["scenarios", "export", str(ROOT / "scenarios/drop.yaml"), "--point", "initial.height=0.5"]
    )
    assert ambiguous.exit_code == 2 and "selects 4 points" in ambiguous.output  # 2 robots x 2 steps


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_root_and_feet_have_collision_corners(name: str) -> None:
    """The buttocks (root body) and the feet give box corners on every robot, their welded children's
    geometry included (G1's pelvis collides through a fixed child); TALOS's are its own body's."""
    world = build_world(Scenario(name="x", robot=name, duration=1.0))
    for body in [world.root_body] + [world.model.body(b).id for b in world.robot.body_groups["feet"]]:
        geoms, corners = body_box_corners(world.model, body)
        assert len(geoms) > 0 and corners.shape == (len(geoms), 8, 3)
        if name == "talos":
            assert set(world.model.geom_bodyid[geoms]) == {body}
    assert np.isfinite(corners).all()


SRDF = """<robot name="r">
  <group_state name="crouch" group="all">
    <joint name="root_joint" value="0 0 0.8 0 0 0 1"/>
    <joint name="knee" value="1.2"/>
    <joint name="hip" value="-0.6"/>
  </group_state>
  <group_state name="zero" group="all">
    <joint name="knee" value="0"/>
  </group_state>
  <disable_collisions link1="thigh" link2="shin" reason="Adjacent"/>
  <disable_collisions link1="base" link2="thigh" reason="Never"/>
  <rotor_params>
    <joint name="knee" mass="2e-5" gear_ratio="100"/>
    <joint name="hip" mass="1e-5"/>
  </rotor_params>
</robot>
"""


def test_srdf_readers(tmp_path: Path) -> None:
    from fallbench.robots.description import (
        read_srdf_armature,
        read_srdf_disabled_collisions,
        read_srdf_postures,
    )

    path = tmp_path / "r.srdf"
    path.write_text(SRDF)
    postures, heights = read_srdf_postures(path)
    assert postures == {"crouch": {"knee": 1.2, "hip": -0.6}, "zero": {"knee": 0.0}}
    assert heights == {"crouch": 0.8}  # the free-flyer's z, only where the state gives it
    assert read_srdf_disabled_collisions(path) == (("thigh", "shin"), ("base", "thigh"))
    armature = read_srdf_armature(path)
    assert armature.keys() == {"knee"} and armature["knee"] == pytest.approx(0.2)  # 2e-5 kg m^2 x 100^2


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_a_joint_without_default_gains_is_named(name: str) -> None:
    robot = get_robot(name)
    assert all(kp > 0 and kd > 0 for kp, kd in map(robot.default_gains, robot.leg_joints))
    with pytest.raises(KeyError, match=rf"robot '{name}': no default gains for joint 'tail_joint'"):
        robot.default_gains("tail_joint")
