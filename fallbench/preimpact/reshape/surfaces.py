"""The planar surfaces of a scene a robot can land on: the floor and the obstacles' faces.

002 assumes a perception pipeline that returns planar surfaces; the simulator knows them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.scenario import Box, Cylinder, Scenario

FLOOR_HALF_EXTENT = 50.0  # m


@dataclass(frozen=True)
class Surface:
    name: str
    center: np.ndarray  # m, world
    normal: np.ndarray  # unit, out of the surface
    tangents: np.ndarray  # (2, 3) unit rows in the surface
    half_extents: np.ndarray  # (2,) m along the tangents; a disc when `radius` is set
    radius: float | None = None

    def closest_point(self, point: np.ndarray) -> np.ndarray:
        """Closest point of the (bounded) surface to `point`."""
        local = self.tangents @ (point - self.center)
        if self.radius is not None:
            norm = float(np.linalg.norm(local))
            local = local * min(1.0, self.radius / norm) if norm > 0 else local
        else:
            local = np.clip(local, -self.half_extents, self.half_extents)
        return self.center + self.tangents.T @ local


def _box_faces(index: int, box: Box) -> list[Surface]:
    yaw = math.radians(box.yaw)
    axes = np.array(
        [[math.cos(yaw), math.sin(yaw), 0.0], [-math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]]
    )
    half = np.array(box.size) / 2
    center = np.array(box.pos)
    faces = []
    for axis, label in ((2, "top"), (0, "+x"), (0, "-x"), (1, "+y"), (1, "-y")):
        sign = -1.0 if label.startswith("-") else 1.0
        others = [a for a in range(3) if a != axis]
        faces.append(
            Surface(
                f"obstacle_{index}:{label}",
                center + sign * half[axis] * axes[axis],
                sign * axes[axis],
                axes[others],
                half[others],
            )
        )
    return faces


def _cylinder_top(index: int, cylinder: Cylinder) -> Surface:
    center = np.array(cylinder.pos) + np.array([0.0, 0.0, cylinder.height / 2])
    return Surface(
        f"obstacle_{index}:top",
        center,
        np.array([0.0, 0.0, 1.0]),
        np.eye(3)[:2],
        np.full(2, cylinder.radius),
        radius=cylinder.radius,
    )


def scene_surfaces(scenario: Scenario) -> list[Surface]:
    """Floor, the five upper faces of each box, the top of each cylinder (its side is not planar)."""
    surfaces = [
        Surface("floor", np.zeros(3), np.array([0.0, 0.0, 1.0]), np.eye(3)[:2], np.full(2, FLOOR_HALF_EXTENT))
    ]
    for index, obstacle in enumerate(scenario.obstacles):
        surfaces += (
            _box_faces(index, obstacle) if isinstance(obstacle, Box) else [_cylinder_top(index, obstacle)]
        )
    return surfaces
