"""Landing order against 000's prescriptions, on hand-made impact sequences."""

from __future__ import annotations

import math

import pytest

from fallbench.scenario import Scenario
from fallbench.sim.impacts import (
    Touch,
    body_sides,
    first_impact_prescribed,
    head_before_hands,
    knees_simultaneous,
    touches,
)
from fallbench.sim.world import build_world


def seq(*items: tuple[float, str, str]) -> list[Touch]:
    return [Touch(t, group, side) for t, group, side in items]


KNEES_TOGETHER_THEN_HANDS = seq(
    (1.0, "knees", "left"), (1.015, "knees", "right"), (1.1, "hands", "left"), (1.3, "head", "")
)
ONE_KNEE = seq((1.0, "knees", "left"), (1.05, "knees", "right"), (1.1, "hands", "left"))
HANDS_FIRST = seq((0.9, "hands", "right"), (1.0, "knees", "left"), (1.2, "knees", "right"))
HEAD_BEFORE_HANDS = seq(
    (1.0, "knees", "left"), (1.0, "knees", "right"), (1.2, "head", ""), (1.25, "hands", "left")
)
ELBOW_FIRST = seq((0.95, "arms", "left"), (0.95, "hands", "left"), (1.0, "torso", ""))
BACK_HANDS_FIRST = seq(
    (0.0, "feet", "left"), (1.0, "hands", "left"), (1.005, "hands", "right"), (1.03, "torso", "")
)
BACK_SAME_STEP = seq((1.0, "hands", "left"), (1.0, "torso", ""))
SIDE_LEFT_HAND = seq((1.0, "knees", "left"), (1.05, "hands", "left"), (1.2, "torso", ""))
SIDE_WRONG_HAND = seq((1.05, "hands", "right"), (1.2, "torso", ""))
SIDE_HEAD = seq((1.05, "hands", "left"), (1.2, "torso", ""), (1.3, "head", ""))


@pytest.mark.parametrize(
    ("landing", "fall_class", "expected"),
    [
        (KNEES_TOGETHER_THEN_HANDS, "front", True),  # both knees within 20 ms, hands before head
        (ONE_KNEE, "front", False),  # 50 ms apart: one knee alone
        (HANDS_FIRST, "front", True),
        (HEAD_BEFORE_HANDS, "front", False),
        (ELBOW_FIRST, "back", False),
        (ELBOW_FIRST, "front", False),
        (BACK_HANDS_FIRST, "back", True),  # the feet (support) do not count
        (BACK_SAME_STEP, "back", False),  # hands not strictly before the buttocks
        (KNEES_TOGETHER_THEN_HANDS, "back", True),  # no torso contact: hands before it
        (SIDE_LEFT_HAND, "left", True),
        (SIDE_LEFT_HAND, "right", False),
        (SIDE_WRONG_HAND, "left", False),
        (SIDE_HEAD, "left", False),
        ([], "front", False),
        (BACK_HANDS_FIRST, "", False),
    ],
)
def test_first_impact_prescribed(landing: list[Touch], fall_class: str, expected: bool) -> None:
    assert first_impact_prescribed(landing, fall_class) is expected


def test_knees_simultaneous() -> None:
    assert knees_simultaneous(KNEES_TOGETHER_THEN_HANDS) == 1.0
    assert knees_simultaneous(ONE_KNEE) == 0.0
    assert (
        knees_simultaneous(seq((1.0, "knees", "left"), (1.1, "torso", ""))) == 0.0
    )  # the other never landed
    assert math.isnan(knees_simultaneous(BACK_HANDS_FIRST))  # no knee contact
    assert math.isnan(
        knees_simultaneous(seq((1.0, "torso", ""), (1.2, "knees", "left"), (1.2, "knees", "right")))
    )  # after the trunk


def test_head_before_hands() -> None:
    assert head_before_hands(HEAD_BEFORE_HANDS)
    assert not head_before_hands(KNEES_TOGETHER_THEN_HANDS)
    assert not head_before_hands(BACK_HANDS_FIRST)  # no head contact
    assert head_before_hands(seq((1.0, "head", "")))  # no hand contact at all


def test_contact_bodies_get_their_limb_side() -> None:
    world = build_world(Scenario(name="s", duration=1.0))
    sides = body_sides(world)
    robot = world.robot
    for side, arm in robot.arms.items():
        assert sides[arm.wrist_frame] == side
    knees = [
        world.model.body(world.model.jnt_bodyid[world.model.joint(j).id]).name for j in robot.knee_joints
    ]
    assert sorted(sides[k] for k in knees) == ["left", "right"]
    assert sides[robot.torso_body] == "" and sides[robot.root_body] == ""
    landing = touches(world, {robot.torso_body: 1.2, robot.arms["left"].wrist_frame: 1.0})
    assert [(x.group, x.side) for x in landing] == [("hands", "left"), ("torso", "")]
