"""The support polygon of a candidate: the feet's soles on the ground, their convex hull
(`events.support_polygon`), and the point of its boundary nearest a given point (the pivot the
robot tips about)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fallbench.sim.events import support_polygon
from fallbench.sim.support import body_box_corners, world_corners


def sole_corners(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> np.ndarray:
    """(k, 2) ground-plane hull of the foot body's collision geometry (its geoms' bounding-box
    corners), m, world: the sole when the foot is flat."""
    geoms, corners = body_box_corners(model, model.body(body).id)
    return support_polygon(world_corners(data, geoms, corners)[:, :2])


def contains(polygon: np.ndarray, point: np.ndarray) -> bool:
    """Whether a point lies inside a counter-clockwise convex polygon (boundary included)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    rel = point[:2] - polygon
    return bool(np.all(edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0] >= -1e-12))


@dataclass(frozen=True)
class Pivot:
    """Where a rigid robot tips: a point of the polygon's boundary, on an edge or at a vertex."""

    point: np.ndarray  # m, (2,) world
    edge: np.ndarray | None  # unit (2,) direction of the edge, None at a vertex


def nearest_pivot(polygon: np.ndarray, point: np.ndarray, vertex_tolerance: float = 1e-3) -> Pivot:
    """The boundary point nearest `point`; at a vertex when it is within `vertex_tolerance` (m) of one."""
    starts = polygon
    edges = np.roll(polygon, -1, axis=0) - polygon
    lengths = np.linalg.norm(edges, axis=1)
    s = np.clip(np.einsum("ij,ij->i", point[:2] - starts, edges) / np.maximum(lengths, 1e-12) ** 2, 0.0, 1.0)
    feet = starts + s[:, None] * edges
    k = int(np.argmin(np.linalg.norm(point[:2] - feet, axis=1)))
    at_vertex = min(s[k], 1.0 - s[k]) * lengths[k] <= vertex_tolerance
    return Pivot(feet[k], None if at_vertex else edges[k] / lengths[k])
