"""The simulated falls against physics that can be computed by hand."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.results.robot_check import stance_scenario, stand, touching_pairs
from fallbench.robots import ROBOTS, get_robot
from fallbench.scenario import Scenario
from fallbench.sim.world import build_world, initial_state


def test_drop_impact_time_and_speed_match_free_fall(drop_scenario: Scenario) -> None:
    row = compute_metrics(simulate_named(drop_scenario, "stiff"))
    g, h = 9.81, 1.0
    assert abs(row["impact_time"] - math.sqrt(2 * h / g)) < 0.005  # s, within one control step
    assert abs(row["impact_speed"] - math.sqrt(2 * g * h)) < 0.05  # m/s
    assert row["fall_reason"] == "freefall" and row["fall_time"] == 0.0
    assert set(row["first_contact_bodies"].split(",")) == {"leg_left_6_link", "leg_right_6_link"}


@pytest.mark.parametrize("robot", ROBOTS)
def test_standing_robot_reads_gravity_and_its_weight(robot: str) -> None:
    scenario = Scenario(name="stand", duration=0.5, robot=robot)
    world = build_world(scenario)
    data = initial_state(world, scenario)
    for _ in range(500):
        mujoco.mj_step(world.model, data)
    mass = world.model.body_subtreemass[world.root_body]
    acc = world.sensor(data.sensordata, "imu_acc")
    assert abs(np.linalg.norm(acc) - 9.81) < 0.2 and acc[2] > 9.5  # specific force, z up, at rest
    assert (
        abs(np.linalg.norm(world.sensor(data.sensordata, "contact:total")[1:4]) - mass * 9.81)
        < 0.02 * mass * 9.81
    )
    assert abs(mass - get_robot(robot).mass) < 1e-6  # kg, the URDF's links, all simulated


@pytest.mark.parametrize("robot", ROBOTS)
def test_robot_stands_still_for_2_s_under_stiff(robot: str) -> None:
    """In its `default` stance, no self-collision at start, the default gains hold the robot at its
    card's standing height (the checks of `fallbench robots check`)."""
    scenario = stance_scenario(robot)
    assert touching_pairs(build_world(scenario), scenario) == []
    standing = stand(robot)
    assert standing.duration == pytest.approx(2.0, abs=scenario.physics_dt)
    assert standing.problems(get_robot(robot).standing_height) == []
    assert 0 < standing.sag < 0.01  # m: the stance settles into the servos' deflection
    assert set(standing.floor_bodies) == set(get_robot(robot).feet.values())  # on its soles
    assert standing.feet_problems(get_robot(robot).body_groups["feet"]) == []  # it stands on its feet


def test_zero_gains_reach_the_knee_stop_and_stiff_does_not(drop_scenario: Scenario) -> None:
    stiff = compute_metrics(simulate_named(drop_scenario, "stiff"))
    zero = compute_metrics(simulate_named(drop_scenario, "zero"))
    assert stiff["knee_limit_margin"] > 0.3
    assert zero["knee_limit_margin"] < 0.0
    assert zero["fell"] and not stiff["fell"]


def test_push_direction_moves_the_robot_that_way() -> None:
    for direction, axis, sign in ((0, 0, 1), (90, 1, 1), (180, 0, -1)):
        scenario = Scenario(
            name="p", duration=0.6, push={"force": 200, "duration": 0.2, "start": 0.0, "direction": direction}
        )
        rec = simulate_named(scenario, "stiff")
        assert sign * (rec.qpos[-1, axis] - rec.qpos[0, axis]) > 0.02


def test_diverging_run_is_flagged() -> None:
    # the largest push allowed, on the lightest body, at the coarsest step
    scenario = Scenario(
        name="boom",
        duration=0.3,
        physics_dt=0.01,
        control_dt=0.01,
        contact={"time_constant": 0.02, "stop_time_constant": 0.02},  # the softest a 10 ms step allows
        push={"force": 10_000, "duration": 0.1, "start": 0.0, "body": "gripper_left_fingertip_1_link"},
    )
    rec = simulate_named(scenario, "stiff")
    assert rec.status == "diverged" and "BADQ" in rec.error
    assert rec.steps < 30
