"""The support polygon of a candidate: the feet's soles on the ground, their convex hull
(`events.support_polygon`), and the point of its boundary nearest a given point (the pivot the
robot tips about)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fallbench.events import signed_distance, support_polygon

UNIT_CORNERS = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T


def sole_corners(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> np.ndarray:
    """(k, 2) ground-plane hull of the foot body's collision geometry (its geoms' bounding-box
    corners), m, world: the sole when the foot is flat."""
    body_id = model.body(body).id
    geoms = np.flatnonzero((model.geom_bodyid == body_id) & (model.geom_contype > 0))
    corners = []
    for geom in geoms:
        centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
        local = centre + UNIT_CORNERS * half
        corners.append(local @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom])
    return support_polygon(np.concatenate(corners)[:, :2])


def contains(polygon: np.ndarray, point: np.ndarray) -> bool:
    """Whether a point lies inside a counter-clockwise convex polygon (boundary included)."""
    return signed_distance(point, polygon) <= 0.0


@dataclass(frozen=True)
class Pivot:
    """Where a rigid robot tips: a point of the polygon's boundary, on an edge or at a vertex."""

    point: np.ndarray  # m, (2,) world
    edge: np.ndarray | None  # unit (2,) direction of the edge, None at a vertex


def nearest_pivot(polygon: np.ndarray, point: np.ndarray, vertex_tolerance: float = 1e-3) -> Pivot:
    """The boundary point nearest `point`; at a vertex when it is within `vertex_tolerance` (m) of one."""
    best: tuple[float, np.ndarray, np.ndarray | None] | None = None
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        edge = b - a
        length = float(np.linalg.norm(edge))
        s = float(np.clip((point[:2] - a) @ edge / length**2, 0.0, 1.0)) if length > 0 else 0.0
        foot = a + s * edge
        distance = float(np.linalg.norm(point[:2] - foot))
        at_vertex = min(s * length, (1 - s) * length) <= vertex_tolerance
        if best is None or distance < best[0] - 1e-12:
            best = (distance, foot, None if at_vertex else edge / length)
    assert best is not None
    return Pivot(best[1], best[2])
