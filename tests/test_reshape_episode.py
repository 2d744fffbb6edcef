"""The reshape strategy in an episode: motors switch to the gain policy chain by chain (002 Sec. V)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.scenario import Push, Scenario
from fallbench.sim.recorder import Recording

BACK_PUSH = Scenario(
    name="back_push", duration=1.5, push=Push(force=200, direction=180, duration=0.2, start=0.1)
)


@pytest.fixture(scope="module")
def reshaped() -> Recording:
    return simulate_named(BACK_PUSH, "zero", "reshape")


def _first_switch(rec: Recording) -> np.ndarray:
    """Servo stiffness (Nm/rad) per motor at the first physics step where the zero policy took any."""
    off = (rec.kp == 0).any(axis=1)
    assert off.any(), "no motor ever switched to the zero policy"
    return rec.kp[np.argmax(off)]


def test_only_the_impacting_chain_switches_first(reshaped: Recording) -> None:
    world = reshaped.world
    assert reshaped.status == "ok"
    first = reshaped.impact_events[0]
    assert first.group != "torso"  # a limb lands first: a chain switches before the rest
    switched = _first_switch(reshaped) == 0
    chain = np.zeros_like(switched)
    chain[select_motors(pinocchio_for(world), set(first.bodies), world.joint_names)] = True
    np.testing.assert_array_equal(switched, chain)  # exactly the impacting body's chain to the root
    assert not switched.all()  # the other chains still reshape


def test_without_reshaping_every_motor_switches_at_once() -> None:
    rec = simulate_named(BACK_PUSH, "zero", "none")
    np.testing.assert_array_equal(_first_switch(rec), 0.0)


def _first_touch(rec: Recording, bodies: list[str]) -> tuple[str, int] | None:
    """(body, physics step) of the first contact among `bodies` after the fall, from the contact
    sensors."""
    world = rec.world
    after = rec.time >= rec.fall_time
    touches = [
        (int(np.argmax(found)), body)
        for body, column in zip(world.contact_bodies, world.contact_found_columns)
        if body in bodies and (found := (rec.sensordata[:, column] > 0) & after).any()
    ]
    return (min(touches)[1], min(touches)[0]) if touches else None


def _contact_point(rec: Recording, body: str, step: int) -> np.ndarray:
    """m: mean of the body's contact points in the recorded state nearest after `step` that has one."""
    model, data = rec.world.model, mujoco.MjData(rec.world.model)
    for k in range(step, min(step + 10, len(rec.time))):
        data.qpos[:], data.qvel[:] = rec.qpos[k], rec.qvel[k]
        mujoco.mj_forward(model, data)
        points = [
            c.pos.copy()
            for c in data.contact[: data.ncon]
            if model.body(body).id in (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2])
        ]
        if points:
            return np.mean(points, axis=0)
    raise AssertionError(f"{body}: no contact in the states after step {step}")


def test_reshape_metrics(reshaped: Recording) -> None:
    row = compute_metrics(reshaped)
    world = reshaped.world
    # The class at detection is the push's. The fall goes the push's way (the base travels straight
    # back); the crouched landing leans the waist back and to the right at the first impact (-128
    # deg, just past the back/right boundary at -135 deg), and the step moves that lean.
    assert row["fall_class_at_detection"] == "back" and row["fall_class_before_impact"] == "back"
    start, impact = np.searchsorted(reshaped.time, [reshaped.fall_time, reshaped.impact_events[0].t])
    travel = reshaped.qpos[impact, :2] - reshaped.qpos[start, :2]
    assert np.linalg.norm(travel) > 0.5 and abs(abs(np.degrees(np.arctan2(travel[1], travel[0]))) - 180) < 5
    assert abs(row["fall_direction_deg"]) > 90.0 and row["fall_class"] in ("back", "left", "right")
    assert row["preimpact_qp_steps"] > 50 and row["preimpact_qp_ms_median"] > 0
    # The first impact: the first contact after the fall of anything but a foot, by the contact sensors.
    group_of = {name.split(":")[2]: group for group, names in world.contact_groups.items() for name in names}
    body, step = _first_touch(reshaped, [b for b in world.contact_bodies if group_of[b] != "feet"])
    assert row["time_to_first_impact"] == pytest.approx(reshaped.time[step] - reshaped.fall_time, abs=0.0051)
    assert row["first_impact_group"] == group_of[body]
    # The landing error of each hand: its first contact point (the state at its sensor's first
    # reading) to the point the strategy aimed it at then.
    for side in ("left", "right"):
        hand = [b for b in world.robot.body_groups["hands"] if f"_{side}_" in b]
        body, step = _first_touch(reshaped, hand)
        target = reshaped.strategy.landing_target(side, reshaped.time[step])
        assert target is not None
        expected = float(np.linalg.norm(_contact_point(reshaped, body, step) - target))
        assert row[f"landing_error_{side}"] == pytest.approx(expected, abs=0.02), side
        assert row[f"landing_error_{side}"] < 0.6  # m: within the arm's reach of its target
    assert not row["head_before_hands"]
