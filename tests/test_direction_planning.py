"""004's planning on hand-made layouts: safe regions (eq. 1, merged overlapping cones, wrapped
angles), scores (eqs. 2-4), the control trigger on straight and bent capture-point paths, and the
pendulum tipping about the support polygon's edge or vertex, and a fall that stops on its polygon."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallbench.analysis.safe_regions import Circle, safe_regions, score
from fallbench.preimpact.direction.candidates import FallState, predict
from fallbench.preimpact.direction.pendulum import rollout
from fallbench.preimpact.direction.scoring import desired_direction
from fallbench.preimpact.direction.support import nearest_pivot
from fallbench.preimpact.direction.trigger import ControlTrigger
from fallbench.sim.events import support_polygon

ORIGIN = np.zeros(2)


def _circle(angle_deg: float, distance: float, radius: float) -> Circle:
    a = math.radians(angle_deg)
    return Circle(np.array([distance * math.cos(a), distance * math.sin(a)]), radius)


def _deg(regions) -> list[tuple[float, float]]:
    return sorted((round(math.degrees(r.start), 6), round(math.degrees(r.width), 6)) for r in regions)


def test_two_objects_leave_two_regions_with_exact_edges() -> None:
    regions = safe_regions([_circle(0, 2, 1), _circle(180, 2, 1)], ORIGIN)  # half-angles asin(1/2) = 30 deg
    assert _deg(regions) == [(30.0, 120.0), (210.0, 120.0)]


def test_a_cone_margin_narrows_every_region_from_both_edges() -> None:
    circles = [_circle(0, 2, 1), _circle(180, 2, 1)]
    assert _deg(safe_regions(circles, ORIGIN, math.radians(10))) == [(40.0, 100.0), (220.0, 100.0)]
    assert safe_regions(circles, ORIGIN, math.radians(61)) == []  # the cones close the regions


def test_a_region_across_zero_degrees_is_one_region() -> None:
    regions = safe_regions([_circle(90, 2, 1), _circle(200, 2, 1)], ORIGIN)
    assert len(regions) == 2
    across = next(r for r in regions if r.contains(0.0))
    assert across.contains(math.radians(350)) and across.contains(math.radians(50))
    assert math.degrees(across.width) == pytest.approx(360 - (200 + 30) + (90 - 30))


def test_overlapping_cones_merge_even_three_at_once() -> None:
    # three cones chained by overlaps: eq. 1 would give 4 - 3 = 1 region only by luck of the count;
    # a fourth object far away leaves exactly two free regions
    circles = [_circle(0, 2, 1), _circle(50, 2, 1), _circle(100, 2, 1), _circle(220, 2, 0.5)]
    regions = safe_regions(circles, ORIGIN)
    assert _deg(regions) == [
        (130.0, pytest.approx(90 - math.degrees(math.asin(0.25)), abs=1e-6)),
        (
            pytest.approx(220 + math.degrees(math.asin(0.25)), abs=1e-6),
            pytest.approx(110 - math.degrees(math.asin(0.25)), abs=1e-6),
        ),
    ]


def test_no_object_is_one_full_region_and_a_surrounding_ring_none() -> None:
    assert _deg(safe_regions([], ORIGIN)) == [(0.0, 360.0)]
    ring = [_circle(a, 1.0, 0.6) for a in range(0, 360, 40)]
    assert safe_regions(ring, ORIGIN) == []


def test_origin_inside_a_grown_circle_blocks_a_half_plane() -> None:
    regions = safe_regions([_circle(0, 0.3, 0.5)], ORIGIN)
    assert _deg(regions) == [(90.0, 180.0)]


def test_score_is_at_most_one_exactly_inside_safe_regions() -> None:
    regions = safe_regions([_circle(10, 2, 0.8), _circle(120, 1.5, 0.7), _circle(250, 2.5, 1.2)], ORIGIN)
    widest = max(regions, key=lambda r: r.width)
    assert score(widest.bisector, regions) == pytest.approx(0.0, abs=1e-12)
    for angle in np.radians(np.arange(0.0, 360.0, 0.5)):
        inside = any(r.contains(angle) for r in regions)
        assert (score(angle, regions) <= 1.0 + 1e-12) == inside
    # wrapped: 359.9 deg and -0.1 deg are the same direction
    assert score(math.radians(359.9), regions) == pytest.approx(score(math.radians(-0.1), regions))


def test_unsafe_direction_desires_the_nearest_bisector() -> None:
    regions = safe_regions([_circle(0, 2, 1), _circle(180, 2, 1)], ORIGIN)  # free: 30-150, 210-330
    assert math.degrees(desired_direction(math.radians(10), regions)) == pytest.approx(90.0)
    assert math.degrees(desired_direction(math.radians(-10), regions)) == pytest.approx(270.0)
    assert score(math.radians(10), regions) == pytest.approx(0.5 * 1 + 0.5 * 2 * 80 / 120)


def _trigger() -> ControlTrigger:
    return ControlTrigger(window=8, tolerance=0.003, min_travel=0.01, timeout=0.2)


def test_control_trigger_fires_on_a_straight_capture_point_path() -> None:
    trigger = _trigger()
    direction = np.array([math.cos(0.7), math.sin(0.7)])
    times = [k * 0.005 for k in range(20)]
    fired = next(t for t in times if trigger.update(t, 0.004 * (t / 0.005) * direction))
    assert trigger.reason == "steady" and fired == pytest.approx(7 * 0.005)


def test_control_trigger_waits_on_a_bent_path_then_times_out() -> None:
    trigger = _trigger()
    point = np.zeros(2)
    for k in range(60):  # a staircase: the capture point turns 90 deg every 3 steps, never collinear over 8
        heading = (k // 3 % 2) * math.pi / 2
        point = point + 0.01 * np.array([math.cos(heading), math.sin(heading)])
        if trigger.update(k * 0.005, point):
            break
    assert trigger.reason == "timeout" and trigger.time == pytest.approx(0.2)


def test_pendulum_tips_normal_to_the_edge_and_along_the_radius_at_a_vertex() -> None:
    square = support_polygon(np.array([[0.1, 0.1], [-0.1, 0.1], [-0.1, -0.1], [0.1, -0.1]]))
    xi = np.array([0.4, 0.05])  # ahead of the +x edge
    pivot = nearest_pivot(square, xi)
    assert pivot.edge is not None and abs(pivot.edge[0]) < 1e-12 and pivot.point == pytest.approx([0.1, 0.05])
    com, velocity = (
        np.array([[0.02, 0.03, 0.9]]),
        np.array([[0.5, 0.3, 0.0]]),
    )  # sideways speed does not matter on a hinge
    edge = rollout(pivot.point[None], pivot.edge[None], com, velocity, 0.0, 0.3)
    assert math.degrees(edge.direction[0]) == pytest.approx(0.0, abs=1e-9)
    corner = nearest_pivot(square, np.array([0.5, 0.5]))
    assert corner.edge is None and corner.point == pytest.approx([0.1, 0.1])
    start = np.array([[0.12, 0.12, 0.9]])  # just past the corner, moving outward along the diagonal
    corner_fall = rollout(corner.point[None], np.zeros((1, 2)), start, np.array([[0.3, 0.3, 0.0]]), 0.0, 0.3)
    assert math.degrees(corner_fall.direction[0]) == pytest.approx(45.0, abs=1e-6)
    assert 0.1 < corner_fall.time[0] < 2.0 and corner_fall.end[0, 2] <= 0.3
    rod = np.linalg.norm(corner_fall.com[0] - [0.1, 0.1, 0.0], axis=1)
    assert rod == pytest.approx(np.full(len(rod), rod[0]), rel=1e-4)  # a rigid rod
    behind = rollout(
        corner.point[None],
        np.zeros((1, 2)),
        np.array([[0.0, 0.0, 0.9]]),
        np.array([[0.05, 0.05, 0.0]]),
        0.0,
        0.3,
    )
    assert math.degrees(behind.direction[0]) == pytest.approx(
        225.0, abs=1e-6
    )  # too slow to pass over the corner: falls back


def test_a_pendulum_falling_back_over_its_polygon_is_a_fall_that_stops() -> None:
    """A step lands 0.25 m ahead of the CoM, the capture point 1 cm past the new front edge: the
    rigid pendulum, too slow to rise over that edge, swings back over the polygon (it predicted a
    backward fall, 176 deg, for a step after 550 N forward, which then fell forward at 35 deg). A
    body standing on the polygon cannot tip into its own soles: the fall stops there."""
    feet = support_polygon(
        np.array(
            [[-0.114, -0.15], [0.096, -0.15], [0.546, 0.02], [0.546, 0.15], [0.336, 0.15], [-0.114, -0.02]]
        )
    )
    com, velocity = (
        np.array([[0.307, 0.022, 0.855]]),
        np.array([[0.866, 0.117, -0.219]]),
    )  # measured at that landing
    state = FallState(com[0], np.zeros(3), 0.0, 0.3)
    roll, stops = predict([feet], com, velocity, state)
    assert roll.end[0, 0] < 0.546 and bool(
        stops[0]
    )  # capture point 1.6 cm past the edge, yet the pendulum falls back
    roll, stops = predict(
        [feet], com, 1.5 * velocity, state
    )  # fast enough: over the front edge, a forward fall
    assert math.degrees(roll.direction[0]) == pytest.approx(0.0, abs=1e-6) and not bool(stops[0])


def test_layout_yaw_turns_the_obstacles_about_the_robot(tmp_path) -> None:
    from fallbench.checks import check_scenario
    from fallbench.scenario import load_scenario_file

    path = tmp_path / "turned.yaml"
    path.write_text(
        "name: turned\nduration: 1.0\nobstacles:\n  - {type: box, pos: [1.2, 0.0, 0.4], size: [0.4, 0.8, 0.8], yaw: 10}\n"
        "  - {type: cylinder, pos: [0.0, -1.0, 0.5], radius: 0.2, height: 1.0}\nsweep:\n  layout_yaw: [0, 90]\n"
    )
    flat, turned = load_scenario_file(path, check=check_scenario)
    assert flat.scenario.obstacles[0].pos == pytest.approx((1.2, 0.0, 0.4))
    assert (
        turned.scenario.obstacles[0].pos == pytest.approx((0.0, 1.2, 0.4))
        and turned.scenario.obstacles[0].yaw == 100
    )
    assert turned.scenario.obstacles[1].pos == pytest.approx((1.0, 0.0, 0.5))
    assert turned.swept == {"layout_yaw": 90} and "layout_yaw=90" in turned.label
