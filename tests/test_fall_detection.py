"""Fall detection: capture point and support polygon on hand-made states, the detectors together,
and TALOS on both sides of its push threshold (FACTS.md: stands after 235 N forward for 0.1 s,
falls after 370 N)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.scenario import Push, Scenario
from fallbench.sim.events import (
    CapturePointDetector,
    FallDetector,
    FreefallDetector,
    ImpactDetector,
    TiltDetector,
    acc_norm,
    capture_point,
    make_fall_detector,
    signed_distance,
    support_distance,
    support_polygon,
    tilt_deg,
)
from fallbench.sim.world import build_world, initial_state

SQUARE = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]])  # m, a 0.2 x 0.1 foot
UPRIGHT = np.eye(3)
STANDING_ACC = np.array([0.0, 0.0, 9.81])
AIRBORNE = np.zeros((0, 2))  # no support points


def _signals(
    torso_rotation: np.ndarray,
    imu_acc: np.ndarray,
    com: np.ndarray,
    com_velocity: np.ndarray,
    support: np.ndarray,
) -> tuple[bool, float, float, float]:
    """What the episode passes to `FallDetector.observe` for a state (`sensing.Sensing.detector_inputs`):
    whether a foot touches, the capture point's distance to the support (m, NaN without support), the
    torso's tilt (deg) and the accelerometer's norm (m/s^2)."""
    supported = len(support) > 0
    distance = (
        support_distance(com.tolist(), com_velocity.tolist(), support.tolist()) if supported else math.nan
    )
    return supported, distance, tilt_deg(torso_rotation), acc_norm(imu_acc)


def test_capture_point_of_a_linear_inverted_pendulum() -> None:
    # z_c = 0.981 m: omega0 = sqrt(9.81 / 0.981) = sqrt(10) 1/s
    xi = capture_point(np.array([0.05, -0.02, 0.981]), np.array([math.sqrt(10) * 0.1, 0.0, -3.0]))
    np.testing.assert_allclose(xi, [0.15, -0.02])


def test_support_polygon_is_the_convex_hull() -> None:
    inner = np.array([[0.1, 0.05], [0.05, 0.02], [0.2, 0.0]])  # inside or repeated
    hull = support_polygon(np.vstack([SQUARE, inner]))
    assert sorted(map(tuple, hull)) == sorted(map(tuple, SQUARE))
    x, y = hull[:, 0], hull[:, 1]
    assert 0.5 * float(x @ np.roll(y, -1) - y @ np.roll(x, -1)) == pytest.approx(
        0.02
    )  # counter-clockwise, 0.02 m^2
    segment = support_polygon(np.array([[0.0, 0.0], [0.1, 0.0], [0.3, 0.0]]))  # collinear: the extreme points
    assert sorted(map(tuple, segment)) == [(0.0, 0.0), (0.3, 0.0)]


@pytest.mark.parametrize(
    ("point", "distance"),
    [
        ((0.1, 0.05), -0.05),  # centre: 5 cm from the long edges
        ((0.19, 0.05), -0.01),
        ((0.25, 0.05), 0.05),  # in front of the toe edge
        ((0.23, 0.14), 0.05),  # off a corner: 3-4-5
        ((-0.1, -0.1), math.hypot(0.1, 0.1)),
    ],
)
def test_signed_distance_to_the_polygon(point: tuple[float, float], distance: float) -> None:
    assert signed_distance(np.array(point), support_polygon(SQUARE)) == pytest.approx(distance)


def test_signed_distance_to_a_degenerate_polygon() -> None:
    edge = support_polygon(np.array([[0.2, 0.0], [0.2, 0.1]]))  # a foot on its toe edge
    assert signed_distance(np.array([0.2, 0.05]), edge) == pytest.approx(0.0)
    assert signed_distance(np.array([0.1, 0.05]), edge) == pytest.approx(0.1)
    assert signed_distance(np.array([0.0, 0.0]), support_polygon(np.array([[0.0, 0.3]]))) == pytest.approx(
        0.3
    )


def test_capture_point_detector_fires_past_the_margin_only() -> None:
    detector = CapturePointDetector(margin=0.02)
    fall = FallDetector(("capture_point",), detector, TiltDetector(15.0), FreefallDetector(3.0, 0.02))
    com = np.array([0.1, 0.05, 0.981])
    omega0 = math.sqrt(10.0)

    def observe(t: float, com_velocity: np.ndarray, support: np.ndarray) -> bool:
        fall.observe(t, *_signals(UPRIGHT, STANDING_ACC, com, com_velocity, support))
        return detector.time is not None

    assert not observe(0.0, np.array([0.115 * omega0, 0.0, 0.0]), SQUARE)  # xi 1.5 cm past the toe
    assert detector.distance == pytest.approx(0.015)
    assert not observe(0.005, np.array([0.3 * omega0, 0.0, 0.0]), AIRBORNE)  # airborne: no judgement
    assert detector.distance == pytest.approx(0.015)  # nor a distance
    assert observe(0.01, np.array([0.125 * omega0, 0.0, 0.0]), SQUARE)  # 2.5 cm past
    assert detector.time == 0.01
    assert observe(0.015, np.zeros(3), SQUARE) and detector.time == 0.01  # the first firing is kept


def _detector(methods: tuple[str, ...]) -> FallDetector:
    return FallDetector(methods, CapturePointDetector(0.02), TiltDetector(15.0), FreefallDetector(3.0, 0.02))


@pytest.mark.parametrize(
    ("methods", "reason", "time"),
    [
        (("capture_point", "tilt", "freefall"), "capture_point", 0.01),
        (("tilt",), "tilt", 0.02),
    ],
)
def test_the_earliest_selected_detector_declares_the_fall(
    methods: tuple[str, ...], reason: str, time: float
) -> None:
    detector = _detector(methods)
    com, fast = np.array([0.1, 0.05, 0.981]), np.array([2.0, 0.0, 0.0])  # xi 0.53 m ahead of the foot
    tilted = np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(0.5), -math.sin(0.5)], [0.0, math.sin(0.5), math.cos(0.5)]]
    )  # 28.6 deg
    assert not detector.observe(0.0, *_signals(UPRIGHT, STANDING_ACC, com, np.zeros(3), SQUARE))
    detector.observe(0.01, *_signals(UPRIGHT, STANDING_ACC, com, fast, SQUARE))
    detector.observe(0.02, *_signals(tilted, STANDING_ACC, com, fast, SQUARE))
    assert (detector.reason, detector.time) == (reason, time)
    assert detector.times == {"capture_point": 0.01, "tilt": 0.02}  # every detector's time, selected or not


def test_method_accepts_one_name_or_a_list() -> None:
    assert Scenario(name="s", duration=1, detection={"method": "tilt"}).detection.method == ("tilt",)
    assert make_fall_detector(
        Scenario(name="s", duration=1, detection={"method": ["tilt", "freefall"]})
    ).methods == ("tilt", "freefall")
    with pytest.raises(ValueError, match="capture_point"):
        Scenario(name="s", duration=1, detection={"method": ["stumble"]})


def test_no_detection_on_a_push_talos_survives() -> None:
    rec = simulate_named(
        Scenario(name="p", duration=1.5, push=Push(force=235, direction=0, duration=0.1)), "stiff"
    )
    assert rec.fall_time is None and rec.fall_times == {}
    assert rec.qpos[-1, 2] > 0.9  # still standing (base height, m)


def test_capture_point_fires_before_tilt_on_a_fall() -> None:
    rec = simulate_named(
        Scenario(name="p", duration=1.0, push=Push(force=370, direction=0, duration=0.1)), "stiff"
    )
    row = compute_metrics(rec)
    assert row["fall_reason"] == "capture_point"
    assert 0.1 < row["fall_time_capture_point"] < 0.35  # within 0.25 s of the push onset (0.1 s)
    assert row["fall_time_capture_point"] + 0.3 < row["fall_time_tilt"] < 1.0
    assert row["fall_time"] == row["fall_time_capture_point"]


def test_posture_noise_moves_the_upper_body_and_leaves_the_robot_standing() -> None:
    """Noise on the legs would tilt the soles and start the robot on one corner (a fall at t = 0)."""
    still = Scenario(name="p", duration=0.5)
    noisy = Scenario(name="p", duration=0.5, initial={"joint_noise": 0.03}, seed=3)
    world = build_world(noisy)
    moved = (
        initial_state(world, noisy).qpos[world.qpos_adr] - initial_state(world, still).qpos[world.qpos_adr]
    )
    legs = np.isin(world.joint_names, world.robot.leg_joints)
    assert (
        np.all(moved[legs] == 0.0)
        and np.all(np.abs(moved[~legs]) <= 0.03)
        and np.abs(moved[~legs]).max() > 0.01
    )
    rec = simulate_named(noisy, "stiff")
    assert rec.fall_time is None and rec.fall_times == {}


def test_freefall_needs_a_whole_hold_and_a_reading_above_resets_it() -> None:
    """Accelerometer readings every 5 ms against a 20 ms hold: dips of 15 ms separated by one normal
    reading never fire; a dip of 20 ms fires, dated from its first reading, and stays fired."""
    detector = FreefallDetector(threshold=3.0, hold=0.02)
    low = np.array([0.0, 0.0, 2.9])  # below the threshold
    readings = [low] * 3 + [STANDING_ACC] + [low] * 4 + [STANDING_ACC]  # 0-10 ms, 15 ms, 20-35 ms, 40 ms
    for k, acc in enumerate(readings):
        assert not detector.observe(0.005 * k, acc_norm(acc)), f"fired at {0.005 * k} s"
    assert detector.since is None  # the last normal reading reset the timer
    for k in range(9, 13):  # 45-60 ms: 15 ms of free fall so far
        assert not detector.observe(0.005 * k, acc_norm(low))
    assert detector.observe(0.065, acc_norm(low)) and detector.time == pytest.approx(0.045)
    assert detector.observe(0.07, acc_norm(STANDING_ACC)) and detector.time == pytest.approx(0.045)


def test_impact_is_the_first_new_contact_after_the_fall_starts() -> None:
    detector = ImpactDetector()
    assert not detector.update(0.0, {"knee"})  # before the fall no contact is an impact
    detector.start({"left_foot", "right_foot"})  # the support when the fall was detected
    detector.start({"hand"})  # later calls keep the first support
    assert not detector.update(0.01, {"left_foot", "right_foot"})
    assert not detector.update(0.02, {"left_foot"})  # losing a support contact is no impact
    assert detector.update(0.03, {"left_foot", "knee", "hand"})
    assert (detector.time, detector.bodies) == (0.03, ["hand", "knee"])
    assert detector.update(0.04, {"head"}) and (detector.time, detector.bodies) == (0.03, ["hand", "knee"])


def test_a_detector_fires_and_the_robot_stays_up() -> None:
    """A push TALOS survives (235 N) with a capture-point margin of -3 cm, inside the support polygon:
    the detector fires, so the run has a fall time, but the robot never leaves its feet: not fallen."""
    scenario = Scenario(
        name="p",
        duration=1.0,
        push=Push(force=235, direction=0, duration=0.1),
        detection={"capture_point_margin": -0.03},
    )
    rec = simulate_named(scenario, "stiff")
    row = compute_metrics(rec)
    assert rec.fall_reason == "capture_point" and 0.1 < rec.fall_time < 0.4
    assert row["fall_time"] == rec.fall_time and row["fell"] is False
    assert rec.qpos[:, 2].min() > 0.9 and not rec.impact_events and np.isnan(row["impact_time"])


def test_a_push_that_topples_the_robot_is_a_fall() -> None:
    rec = simulate_named(
        Scenario(name="p", duration=1.5, push=Push(force=370, direction=0, duration=0.1)), "stiff"
    )
    row = compute_metrics(rec)
    assert row["fell"] is True and row["final_base_height"] < 0.4 and rec.impact_events
