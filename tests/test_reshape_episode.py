"""The reshape strategy in an episode: motors switch to the gain policy chain by chain (002 Sec. V)."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.registry import simulate_named
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


def test_reshape_metrics(reshaped: Recording) -> None:
    row = compute_metrics(reshaped)
    # The class at detection is the push's; at the first impact it is the fall's outcome, which the
    # step moves for this reshaped back fall (1 / 0.5 / 0.25 ms: back / front / back, first touching
    # a wrist / a thigh / the torso): the reshaped landing is not converged in the step.
    assert row["fall_class_at_detection"] == "back" and row["fall_class_before_impact"] == "back"
    assert row["fall_class"] in ("front", "back", "left", "right")
    assert row["preimpact_qp_steps"] > 50 and row["preimpact_qp_ms_median"] > 0
    assert 0 < row["landing_error"] < 2.0  # m from the chosen BIP to the wrist's first contact
    assert row["time_to_first_impact"] == pytest.approx(reshaped.impact_events[0].t - reshaped.fall_time)
    # Which limb lands first is the fall's outcome, and it moves with the step: at 1 ms a wrist
    # (1.01 s), at 0.5 and 0.25 ms a thigh (0.91 and 0.98 s); the row must report what happened.
    assert row["first_impact_group"] == reshaped.impact_events[0].group
    assert not row["head_before_hands"]
