"""The support polygon: the feet's sole rectangles on the ground, their convex hull, and the
point of its boundary nearest a given point (the pivot the robot tips about)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np


def sole_corners(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> np.ndarray:
    """(4, 2) ground projection of the bottom face of the foot body's box geom, m, world."""
    body_id = model.body(body).id
    box = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == body_id and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX)
    half = model.geom_size[box]
    signs = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float)
    local = np.column_stack([signs * half[:2], -half[2] * np.ones(4)])
    corners = local @ data.geom_xmat[box].reshape(3, 3).T + data.geom_xpos[box]
    return corners[:, :2]


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise hull of 2-D points (monotone chain), (k, 2)."""
    pts = sorted(map(tuple, np.asarray(points, dtype=float)))
    if len(pts) <= 2:
        return np.array(pts)

    def half(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        chain: list[tuple[float, float]] = []
        for p in seq:
            while len(chain) >= 2 and _cross(chain[-2], chain[-1], p) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


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
