"""The direction strategy in an episode: control trigger after the fall trigger, a forced step that
lands is a planned contact (not an impact), and the obstacle metrics of every run."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.analysis.obstacles import obstacle_metrics
from fallbench.assembly import simulate_named
from fallbench.checks import load
from fallbench.scenario import Scenario
from fallbench.sim.impacts import ImpactEvent
from fallbench.sim.recorder import Recording
from fallbench.sim.world import build_world, initial_state

RING4 = [
    {"type": "box", "pos": [1.25, 0.0, 0.375], "size": [0.6, 0.6, 0.75]},
    {"type": "cylinder", "pos": [-0.113, 1.295, 0.85], "radius": 0.25, "height": 1.7},
    {"type": "box", "pos": [-0.479, -1.316, 0.9], "size": [0.4, 1.0, 1.8], "yaw": 70},
    {"type": "cylinder", "pos": [0.849, -0.849, 0.75], "radius": 0.15, "height": 1.5},
]
SHIPPED = Path(__file__).resolve().parents[1] / "scenarios" / "direction.yaml"
FORWARD = Scenario(
    name="dir_forward",
    duration=1.1,
    push={"force": 384, "duration": 0.1, "start": 0.1, "direction": 0},
    obstacles=RING4,
    policy_params={"direction": {"mode": "take_step"}},
)


def _shipped(name: str) -> Scenario:
    """The scenario of a point of the shipped direction.yaml."""
    return next(p.scenario for p in load([SHIPPED]) if p.scenario.name == name)


@pytest.fixture(scope="module")
def stepped() -> Recording:
    return simulate_named(FORWARD, "stiff", "direction")


def test_a_planned_step_lands_without_counting_as_an_impact(stepped: Recording) -> None:
    strategy = stepped.strategy
    assert stepped.status == "ok" and strategy is not None and strategy.plan is not None
    assert strategy.plan.chosen.kind == "take_step" and strategy.plan.inertia_shaping == ""
    assert (
        stepped.fall_time
        < strategy.trigger.time
        <= stepped.fall_time + strategy.config.trigger_timeout + 1e-9
    )
    assert strategy.step_done is not None and strategy.step_done > strategy.trigger.time  # the foot landed
    swing_foot = stepped.world.robot.feet[strategy.plan.chosen.swing]
    assert all(swing_foot not in event.bodies for event in stepped.impact_events)


def test_direction_metrics(stepped: Recording) -> None:
    row = compute_metrics(stepped)
    assert row["direction_strategy"].startswith("take_step_")
    assert row["control_trigger_reason"] == "steady"  # a straight capture-point path, before the timeout
    assert row["n_safe_regions"] == 2
    # the step keeps the robot off the ring: no obstacle sensor ever fires, some clearance is left
    assert row["obstacle_hit"] is False and row["obstacle_clearance_at_impact"] > 0
    assert not any(
        (stepped.world.sensor(stepped.sensordata, name)[:, 0] > 0).any()
        for name in stepped.world.obstacle_sensors
    )
    assert row["fall_direction_error_deg"] == pytest.approx(
        min(
            abs(row["predicted_fall_direction_deg"] - row["actual_fall_direction_deg"]),
            360 - abs(row["predicted_fall_direction_deg"] - row["actual_fall_direction_deg"]),
        )
    )
    assert row["direction_plan_ms"] > 0


def test_none_gets_the_obstacle_metrics_too() -> None:
    row = compute_metrics(simulate_named(FORWARD.model_copy(update={"duration": 0.6}), "stiff", "none"))
    assert "direction_strategy" not in row and row["n_safe_regions"] == 2
    forward = row["actual_fall_direction_deg"]  # deg in [0, 360): the push's way, 0 deg
    assert min(forward, 360.0 - forward) < 5.0
    assert (
        row["actual_fall_end"] == "run_end"
    )  # 0.5 s after the push the CoM is still high, no object touched


def test_actual_direction_says_whether_the_com_touched_down() -> None:
    """004 Fig. 6's backward fall into free space reaches the touchdown height; its direction is backward,
    and the direction at the first impact is the CoM's, from the fall trigger to that impact."""
    rec = simulate_named(_shipped("dir_fig6"), "stiff", "none")
    row = compute_metrics(rec)
    assert row["actual_fall_end"] == "touchdown" and row["actual_fall_direction_deg"] == pytest.approx(
        180.0, abs=5.0
    )
    # straight back: the base's own travel from the fall trigger to the first impact (qpos, not the CoM)
    start, impact = np.searchsorted(rec.time, [rec.fall_time, rec.impact_events[0].t])
    travel = rec.qpos[impact, :2] - rec.qpos[start, :2]
    assert np.linalg.norm(travel) > 0.5  # m: it did fall that way
    assert row["impact_fall_direction_deg"] == pytest.approx(_deg(travel), abs=1.0)


def _deg(vector: np.ndarray) -> float:
    """deg in [0, 360) of a ground-plane vector."""
    return math.degrees(math.atan2(vector[1], vector[0])) % 360.0


def test_actual_direction_stops_at_the_first_object_contact() -> None:
    """004 Fig. 1's forward fall without control hits the table before the CoM is down: its direction
    is read at that contact (the table, not the fall, sets where the robot ends)."""
    rec = simulate_named(_shipped("dir_fig1"), "stiff", "none")
    row = compute_metrics(rec)
    assert row["obstacle_hit"] and row["actual_fall_end"] == "object"
    touching = np.any(
        [rec.world.sensor(rec.sensordata, name)[:, 0] > 0 for name in rec.world.obstacle_sensors], axis=0
    )
    first = int(np.flatnonzero(touching)[0])  # the physics step the table is first touched
    travel = rec.qpos[first, :2] - rec.qpos[int(np.searchsorted(rec.time, rec.fall_time)), :2]
    assert np.linalg.norm(travel) > 0.5  # m
    assert row["actual_fall_direction_deg"] == pytest.approx(_deg(travel), abs=1.0)


# A hand-built recording: the standing robot moved bodily (its free joint translated) along a path
# of straight legs, 5 physics steps a control step; a rigid translation moves the CoM with the base,
# so the directions are those of the legs. Fall trigger at 0.1 s; before it the robot drifts to 270
# deg (a reading from t = 0 would bend); 0.1-0.2 s: 0.2 m at 30 deg, an impact at 0.2 s; 0.2-0.3 s:
# 0.1 m at 90 deg; 0.3-0.4 s: 0.3 m at 200 deg (a reading at the run's end would bend).
LEGS = [(0.0, 0.1, 270.0, 0.05), (0.1, 0.2, 30.0, 0.2), (0.2, 0.3, 90.0, 0.1), (0.3, 0.4, 200.0, 0.3)]


@pytest.fixture(scope="module")
def ring_world():
    scenario = Scenario(name="ring", duration=0.4, physics_dt=0.001, obstacles=RING4)
    return scenario, build_world(scenario)


def _handmade(
    ring_world,
    contact: tuple[float, float] | None = None,
    drop: float | None = None,
    impacts: tuple[float, ...] = (0.05, 0.2),
) -> Recording:
    """The recording of LEGS; `contact`: s (from, to) the first obstacle's sensor reads a contact;
    `drop`: s from which the base is 0.7 m lower (the CoM under the touchdown height)."""
    scenario, world = ring_world
    steps, nu = 401, len(world.joint_names)
    time = np.arange(steps) * scenario.physics_dt
    qpos = np.tile(initial_state(world, scenario).qpos, (steps, 1))
    for begin, end, heading, length in LEGS:
        along = np.clip((time - begin) / (end - begin), 0.0, 1.0)[:, None]
        qpos[:, :2] += (
            along * length * np.array([math.cos(math.radians(heading)), math.sin(math.radians(heading))])
        )
    if drop is not None:
        qpos[time >= drop - 1e-9, 2] -= 0.7
    sensordata = np.zeros((steps, world.model.nsensordata))
    # the CoM sensor reads the recorded states, as MuJoCo computes it inside each physics step
    data, com = mujoco.MjData(world.model), world.sensors["com_pos"].start
    for row, state in zip(sensordata, qpos):
        data.qpos[:] = state
        mujoco.mj_kinematics(world.model, data)
        mujoco.mj_comPos(world.model, data)
        row[com : com + 3] = data.subtree_com[world.root_body]
    if contact is not None:
        first = world.sensors[world.obstacle_sensors[0]].start
        sensordata[(time >= contact[0] - 1e-9) & (time < contact[1] - 1e-9), first] = 1.0
    zeros = np.zeros((steps, nu))
    return Recording(
        world, scenario, time, sensordata, qpos, np.zeros((steps, world.model.nv)), zeros, zeros, zeros,
        zeros, zeros, fall_time=0.1, fall_reason="capture_point", fall_times={"capture_point": 0.1},
        impact_time=None, impact_bodies=[], controller_ms=np.zeros(1), switch_time=np.full(nu, np.nan),
        impact_events=[ImpactEvent(t, "hands", [], {}, []) for t in impacts], steps=steps,
    )  # fmt: skip


def _leg(*legs: int) -> float:
    """deg: direction of the sum of the given LEGS."""
    return _deg(
        sum(
            LEGS[i][3] * np.array([math.cos(math.radians(LEGS[i][2])), math.sin(math.radians(LEGS[i][2]))])
            for i in legs
        )
    )


@pytest.mark.parametrize(
    ("contact", "drop", "end", "legs"),
    [
        ((0.3, 0.4), None, "object", (1, 2)),  # read at the first contact, not at the run's end
        ((0.03, 0.06), None, "run_end", (1, 2, 3)),  # a contact before the fall trigger does not end it
        ((0.03, 0.25), None, "object", (1,)),  # ... one that lasts past it does, at its first sample after
        (None, 0.2, "touchdown", (1,)),
        ((0.3, 0.4), 0.2, "touchdown", (1,)),  # the earlier of touchdown and contact
        ((0.2, 0.4), 0.3, "object", (1,)),
    ],
)
def test_actual_direction_on_a_handmade_path(ring_world, contact, drop, end, legs) -> None:
    rec = _handmade(ring_world, contact, drop)
    row = obstacle_metrics(rec, rec.fall_time)
    assert row["actual_fall_end"] == end
    assert row["actual_fall_direction_deg"] == pytest.approx(_leg(*legs), abs=1e-6)
    # the first impact after the trigger (0.2 s, not 0.05 s): 30 deg
    assert row["impact_fall_direction_deg"] == pytest.approx(30.0, abs=1e-6)
    assert row["obstacle_hit"] is (contact is not None)


def test_impact_direction_needs_an_impact_after_the_trigger(ring_world) -> None:
    rec = _handmade(ring_world, impacts=(0.05,))
    assert math.isnan(obstacle_metrics(rec, rec.fall_time)["impact_fall_direction_deg"])
    assert math.isnan(obstacle_metrics(rec, None)["actual_fall_direction_deg"])


FAITHFUL_004 = {  # 004's reading as first built (docs/methods/direction.md, Results on TALOS)
    "robot_radius": 0.45,
    "partial_shaping": "eq7",
    "whole_body_shaping": "on",
    "step_time_offset": 0.0,
    "step_time_per_m": 1.0,
    "when_none_safe": "best",
}


def _with_direction(scenario: Scenario, **params: object) -> Scenario:
    return scenario.model_copy(update={"policy_params": {**scenario.policy_params, "direction": params}})


def test_whole_body_shaping_waits_for_the_step_to_land() -> None:
    """004 Sec. I-c: whole-body inertia shaping cannot start before the foot placement is complete.
    004 Fig. 7's layout (351 N forward), with whole-body shaping on: no step is predicted safe, so
    tracking switches to whole-body shaping, but only after the step's foot is down; switching in
    flight abandoned the step."""
    rec = simulate_named(_with_direction(_shipped("dir_fig7"), **FAITHFUL_004), "stiff", "direction")
    strategy = rec.strategy
    assert strategy is not None and strategy.plan is not None and strategy.plan.chosen.kind == "take_step"
    assert strategy.plan.inertia_shaping == "wbis"  # tracking did switch to whole-body shaping
    assert strategy.step_done is not None  # the foot landed
    assert strategy.step_done <= strategy.tracking_switch < rec.time[-1]  # ... once the foot was down


def test_a_step_with_partial_inertia_shaping_lands() -> None:
    """004 Fig. 8/10 (393 N forward, Take a Step + partial inertia shaping): the arms' motion carries
    the descending foot 4.4 cm past its target onto the ground; the step must end there, or the
    swing leg goes on pushing a loaded foot and the step is never complete."""
    scenario = next(
        p.scenario
        for p in load([SHIPPED])
        if p.scenario.name.startswith("dir_fig10")
        and p.scenario.policy_params["direction"]["mode"] == "take_step_pis"
    )
    rec = simulate_named(scenario, "stiff", "direction")
    strategy = rec.strategy
    assert strategy is not None and strategy.plan is not None and strategy.plan.label.endswith("+pis")
    assert strategy.step_done is not None and strategy.step_done < rec.impact_events[0].t
    row = compute_metrics(rec)
    assert row["step_completed"] is True and row["step_error"] <= strategy.config.step_tolerance


def test_whole_body_shaping_keeps_both_grounded_feet_where_they_are() -> None:
    """004 Fig. 10's push with whole-body inertia shaping from double support (No Action): J_I holds
    only the stance foot, so the shaping must not also swing the other grounded leg; it scissored the
    hips by +-1.5 rad, the feet could not follow and the body folded (CoM 0.88 -> 0.70 m)."""
    scenario = next(
        p.scenario
        for p in load([SHIPPED])
        if p.scenario.name.startswith("dir_fig10")
        and p.scenario.policy_params["direction"]["mode"] == "whole_body_is"
    )
    rec = simulate_named(scenario.model_copy(update={"duration": 0.6}), "stiff", "direction")
    strategy = rec.strategy
    assert strategy is not None and strategy.plan is not None and strategy.plan.label == "no_action+wbis"
    model, data = rec.world.model, mujoco.MjData(rec.world.model)
    feet = [model.body(body).id for body in rec.world.robot.feet.values()]

    def feet_apart(sample: int) -> np.ndarray:
        """The feet's relative position (m) with the commanded joint angles."""
        data.qpos[:] = rec.qpos[sample]
        data.qpos[rec.world.qpos_adr] = rec.q_ref[sample]
        mujoco.mj_kinematics(model, data)
        return data.xpos[feet[0]] - data.xpos[feet[1]]

    start = int(np.searchsorted(rec.time, strategy.trigger.time))
    assert np.abs(rec.q_ref[-1] - rec.q_ref[start]).max() > 0.3  # rad: the shaping did move joints
    np.testing.assert_allclose(feet_apart(len(rec.time) - 1), feet_apart(start), atol=0.01)
