"""A foot set down while a foot of the other leg supports the robot is a step, not the fall's
impact (docs/detection.md: G1 rocked onto one foot); in a drop the feet's first contact stays the impact."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fallbench.assembly import simulate_named
from fallbench.checks import load
from fallbench.scenario import Scenario
from fallbench.sim.recorder import Recording

RANDOM = Path(__file__).resolve().parents[1] / "scenarios" / "random.yaml"


def _g1_push(seed: int) -> Scenario:
    points = [p for p in load([RANDOM]) if p.scenario.name == "random_push" and p.scenario.robot == "g1"]
    return next(p.scenario for p in points if p.label.rsplit("#s", 1)[1] == str(seed))


@pytest.fixture(scope="module")
def rocked() -> Recording:
    """Seed 2: a sideways push rocks G1 onto its right foot; the left comes down 10 ms after
    reshape starts (it used to be the first impact, and the crouch that followed felled G1)."""
    return simulate_named(_g1_push(2), "stiff", "reshape")


@pytest.mark.slow
def test_a_step_is_no_impact_and_reshape_hands_back(rocked: Recording) -> None:
    assert rocked.status == "ok"
    assert rocked.strategy_start_time is not None
    assert rocked.impact_time is None and not rocked.impact_events  # the step is no impact
    assert rocked.hand_back_time is not None  # the stepped foot joined the support: the fall is over
    assert np.isnan(rocked.switch_time).all()  # no motor under the gain policy


@pytest.mark.parametrize("robot", ["talos", "g1"])
def test_a_drop_lands_on_the_feet(robot: str) -> None:
    # nothing touches when the fall is detected: the first foot down is the impact
    rec = simulate_named(Scenario(name="drop", robot=robot, duration=0.3, initial={"height": 0.05}), "stiff")
    assert rec.impact_time is not None
    assert rec.impact_events[0].group == "feet"
