"""The direction strategy in an episode: control trigger after the fall trigger, a forced step that
lands is a planned contact (not an impact), and the obstacle metrics of every run."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.preimpact.direction.outcome import com_path
from fallbench.registry import load, simulate_named
from fallbench.scenario import Scenario
from fallbench.sim.recorder import Recording

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
    every = round(rec.scenario.control_dt / rec.scenario.physics_dt)
    path = com_path(rec, every)
    start = int(np.searchsorted(rec.time[::every], rec.fall_time))
    impact = int(np.searchsorted(rec.time[::every], rec.impact_events[0].t))
    assert start < impact
    delta = path[impact, :2] - path[start, :2]
    assert row["impact_fall_direction_deg"] == pytest.approx(
        math.degrees(math.atan2(delta[1], delta[0])) % 360.0, abs=1e-9
    )


def test_actual_direction_stops_at_the_first_object_contact() -> None:
    """004 Fig. 1's forward fall without control hits the table before the CoM is down: its direction
    is read at that contact (the table, not the fall, sets where the robot ends)."""
    rec = simulate_named(_shipped("dir_fig1"), "stiff", "none")
    row = compute_metrics(rec)
    assert row["obstacle_hit"] and row["actual_fall_end"] == "object"
    touching = np.any(
        [rec.world.sensor(rec.sensordata, name)[:, 0] > 0 for name in rec.world.obstacle_sensors], axis=0
    )
    every = round(rec.scenario.control_dt / rec.scenario.physics_dt)
    path = com_path(rec, every)
    start = int(np.searchsorted(rec.time[::every], rec.fall_time))
    contact = int(np.flatnonzero(touching)[0]) // every
    delta = path[contact, :2] - path[start, :2]
    assert row["actual_fall_direction_deg"] == pytest.approx(
        math.degrees(math.atan2(delta[1], delta[0])) % 360.0, abs=1e-9
    )


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
