"""Fall direction, fall class, landing-point search and reach polyhedra on hand-made geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallbench.dynamics.fall_direction import FallDirection, fall_class
from fallbench.dynamics.model import PinocchioModel
from fallbench.preimpact.reshape.landing import Candidate, choose, circle_plane_crossings, landing_candidates
from fallbench.preimpact.reshape.reach import ReachPolyhedron, compute_polyhedra
from fallbench.preimpact.reshape.surfaces import Surface, scene_surfaces
from fallbench.scenario import Box, Scenario
from fallbench.sim.world import World

X, Y, Z = np.eye(3)


def _horizontal(height: float, center_x: float = 0.0, half: float = 10.0) -> Surface:
    return Surface("s", np.array([center_x, 0.0, height]), Z, np.eye(3)[:2], np.array([half, half]))


def _rotation_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _pitch(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_fall_direction_is_eq2_and_falls_back_to_the_lean() -> None:
    direction = FallDirection(np.array([0.1, 0.2, 0.9]))
    np.testing.assert_allclose(
        direction.update(np.array([0.4, 0.6, 0.5]), Z), [0.6, 0.8, 0.0]
    )  # (0.3, 0.4)/0.5
    np.testing.assert_allclose(direction.update(np.array([0.1, 0.2, 0.8]), _pitch(20) @ Z), X, atol=1e-12)


@pytest.mark.parametrize(("direction", "expected"), [(X, "front"), (-X, "back"), (Y, "left"), (-Y, "right")])
def test_fall_class_relative_to_the_torso(direction: np.ndarray, expected: str) -> None:
    yawed = _rotation_z(90)  # torso facing world +y
    assert fall_class(direction, np.eye(3)) == expected
    assert fall_class(yawed @ direction, yawed) == expected
    assert fall_class(direction, _pitch(120)) == expected  # torso pitched past horizontal, still facing +x


def test_circle_crosses_planes_where_hand_computation_says() -> None:
    assert [
        abs(phi) for phi in circle_plane_crossings(np.zeros(3), 1.0, X, _horizontal(0.0))
    ] == pytest.approx([0.0, math.pi])
    phis = circle_plane_crossings(np.zeros(3), 1.0, X, _horizontal(0.5))
    assert phis == pytest.approx([math.pi / 6, 5 * math.pi / 6])
    assert circle_plane_crossings(np.zeros(3), 1.0, X, _horizontal(1.5)) == []


def test_mpip_bip_and_selection() -> None:
    cube = ReachPolyhedron(
        np.array([[x, y, z] for x in (-0.3, 0.3) for y in (-0.3, 0.3) for z in (-0.3, 0.3)])
    )
    shoulder = np.array([0.0, 0.0, 1.0])
    table = _horizontal(0.5, center_x=2.0, half=0.5)  # spans x in [1.5, 2.5]
    floor = _horizontal(0.0)
    candidates = landing_candidates(np.zeros(3), shoulder, X, [floor, table], np.eye(3), cube)
    by_name = {id(c.surface): c for c in candidates}
    on_table, on_floor = by_name[id(table)], by_name[id(floor)]
    np.testing.assert_allclose(on_table.mpip, [math.cos(math.pi / 6), 0, 0.5], atol=1e-12)
    np.testing.assert_allclose(on_table.bip, [1.5, 0, 0.5], atol=1e-12)  # table edge nearest the MPIP
    assert not on_table.reachable  # 0.634 m from the MPIP: outside a 0.6 m cube however it is turned
    np.testing.assert_allclose(on_floor.mpip, [1.0, 0, 0.0], atol=1e-12)
    assert on_floor.reachable  # BIP = MPIP
    assert choose(candidates) is on_floor  # the only reachable one
    big = ReachPolyhedron(cube.vertices * 3)
    assert (
        choose(landing_candidates(np.zeros(3), shoulder, X, [floor, table], np.eye(3), big)).surface is table
    )  # highest


def test_nearest_bip_when_none_is_reachable() -> None:
    far, near = _horizontal(0.0), _horizontal(0.2)
    a = Candidate(far, np.zeros(3), np.array([1.0, 0, 0]), 0.0, False)
    b = Candidate(near, np.zeros(3), np.array([0.5, 0, 0]), 0.0, False)
    assert choose([a, b]) is b
    assert choose([]) is None


def test_box_faces_and_closest_point() -> None:
    surfaces = scene_surfaces(
        Scenario(
            name="t", duration=1.0, obstacles=[Box(type="box", pos=(1.0, 0.0, 0.5), size=(0.4, 0.6, 1.0))]
        )
    )
    names = [s.name for s in surfaces]
    assert names == [
        "floor",
        "obstacle_0:top",
        "obstacle_0:+x",
        "obstacle_0:-x",
        "obstacle_0:+y",
        "obstacle_0:-y",
    ]
    top, front = surfaces[1], surfaces[3]
    np.testing.assert_allclose(top.closest_point(np.array([2.0, 0.1, 3.0])), [1.2, 0.1, 1.0])
    np.testing.assert_allclose(front.normal, -X)
    np.testing.assert_allclose(front.closest_point(np.array([0.0, 0.0, 2.0])), [0.8, 0.0, 1.0])


def test_reach_polyhedra_split_by_the_coronal_plane(world: World, robot: PinocchioModel) -> None:
    polyhedra = compute_polyhedra(robot.model, world.robot)
    assert set(polyhedra) == {"left:front", "left:back", "right:front", "right:back"}
    front = ReachPolyhedron(polyhedra["left:front"])
    assert front.contains(np.zeros(3))  # the centroid
    assert not front.contains(np.array([1.0, 0.0, 0.0]))  # beyond the arm's length (~0.6 m)
    extent = polyhedra["left:front"].max(axis=0) - polyhedra["left:front"].min(axis=0)
    assert (
        0.3 < extent[0] < 0.8 and 0.6 < extent[2] < 1.4
    )  # half the reach forward, the full reach vertically
