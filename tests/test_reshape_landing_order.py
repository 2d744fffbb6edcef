"""000's landing order under `reshape` on falls the shipped push.yaml does not hold.

Back falls: the hands must land before the buttocks (000 Sec. IV-C). A crouched TALOS sits on a
thigh and a hip first, so the buttocks' point the hands aim below must include them (`seat_bodies`);
aimed below the pelvis alone, the hands landed after the thigh. Front falls: without a crouch the
hands, or both knees together, land first; with the 1.6 rad crouch one knee landed alone.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import run_world, simulate_named
from fallbench.preimpact.reshape.controller import ReshapeConfig, seat_bodies
from fallbench.scenario import Scenario, load_scenario_file

DEV = Path(__file__).resolve().parents[1] / "scenarios" / "reshape_dev.yaml"


def _dev_point(label: str) -> Scenario:
    """A point of the development suite, cut to 2 s (every first impact is before 1.5 s)."""
    (point,) = [p for p in load_scenario_file(DEV) if p.label == label]
    return point.scenario.model_copy(update={"duration": 2.0})


def test_the_seat_holds_the_pelvis_hips_and_thighs() -> None:
    world = run_world(Scenario(name="stand", duration=0.1))
    model = world.model
    seat = seat_bodies(world)
    assert world.root_body in seat
    for joint in world.robot.knee_joints:
        thigh = model.body_parentid[model.jnt_bodyid[model.joint(joint).id]]
        assert thigh in seat and model.jnt_bodyid[model.joint(joint).id] not in seat


def test_elbow_back_is_a_fraction() -> None:
    with pytest.raises(ValueError, match="elbow_back"):
        ReshapeConfig(elbow_back=1.5)


@pytest.mark.slow
def test_an_oblique_back_fall_lands_the_hands_before_the_seat() -> None:
    # before the fix: a thigh at 0.92 s, the hips at 0.93 s, the hands at 1.18 s
    row = compute_metrics(
        simulate_named(
            _dev_point("reshape_dev_fixed[push.direction=160,push.force=200]#s0"), "stiff", "reshape"
        )
    )
    assert row["fall_class"] == "back"
    assert row["first_impact_group"] == "hands"
    assert row["first_impact_prescribed"]


@pytest.mark.slow
def test_a_diagonal_front_fall_does_not_land_one_knee_alone() -> None:
    # before the fix (1.6 rad crouch, leg posture weight 10): one knee alone at 0.95 s
    label = "reshape_dev_front[friction=0.812548,push.direction=19.8607,push.force=375.137,push.start=0.145041]#s7"
    row = compute_metrics(simulate_named(_dev_point(label), "stiff", "reshape"))
    assert row["fall_class"] == "front"
    assert row["first_impact_group"] == "hands" or row["knees_simultaneous"] == 1.0
    assert row["first_impact_prescribed"]
