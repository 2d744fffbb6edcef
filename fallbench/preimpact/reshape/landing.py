"""Landing-point search (002 Sec. IV-B): where each wrist should meet the environment.

The robot is a rigid stick pivoting about its ground contact in the fall plane (spanned by the
fall direction and gravity). Each shoulder then moves on a circle. Its intersections with the
planes of the scene's surfaces are the most probable impact points (MPIP); the closest point of
each surface to its MPIP is a best impact point (BIP). A BIP is reachable when, with the arm's
reachable-wrist polyhedron centred on the MPIP, it lies inside the polyhedron; the highest
reachable BIP wins (it is met soonest), else the BIP nearest to its MPIP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.dynamics.vectors import UP, cross
from fallbench.preimpact.reshape.reach import ReachPolyhedron
from fallbench.preimpact.reshape.surfaces import Surface

LOWEST_ANGLE = -math.pi / 6  # rad below the pivot's horizontal the shoulder may still travel


@dataclass(frozen=True)
class Candidate:
    surface: Surface
    mpip: np.ndarray  # m, shoulder position where it crosses the surface's plane
    bip: np.ndarray  # m, closest point of the surface to the MPIP
    angle: float  # rad, stick angle above the horizontal at the crossing
    reachable: bool


def rotated(vector: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """`vector` turned by `angle` (rad) about the unit `axis` (Rodrigues' formula)."""
    cos, sin = math.cos(angle), math.sin(angle)
    return vector * cos + cross(axis, vector) * sin + axis * (float(axis @ vector) * (1.0 - cos))


def circle_plane_crossings(
    center: np.ndarray, radius: float, direction: np.ndarray, surface: Surface
) -> list[float]:
    """Angles phi of the points center + radius (cos phi direction + sin phi up) on the surface's plane."""
    a = radius * float(surface.normal @ direction)
    b = radius * float(surface.normal @ UP)
    r = float(surface.normal @ (surface.center - center))
    amplitude = math.hypot(a, b)
    if amplitude < 1e-12 or abs(r) > amplitude:
        return []
    base, spread = math.atan2(b, a), math.acos(r / amplitude)
    return sorted({math.remainder(base + spread, 2 * math.pi), math.remainder(base - spread, 2 * math.pi)})


def landing_candidates(
    pivot: np.ndarray,
    shoulder: np.ndarray,
    direction: np.ndarray,
    surfaces: list[Surface],
    torso_rotation: np.ndarray,
    reach: ReachPolyhedron,
) -> list[Candidate]:
    """One candidate per surface the shoulder's circle crosses before it ends below the pivot.

    `pivot` is the stick's ground contact shifted sideways to this shoulder, so each shoulder
    keeps its own circle; `direction` is the unit fall direction in the ground plane.
    """
    relative = shoulder - pivot
    radius = float(np.linalg.norm(relative))
    now = math.atan2(float(relative @ UP), float(relative @ direction))
    tilt_axis = cross(UP, direction)
    candidates = []
    for surface in surfaces:
        ahead = [
            phi
            for phi in circle_plane_crossings(pivot, radius, direction, surface)
            if LOWEST_ANGLE <= phi <= now
        ]
        if not ahead:
            continue
        phi = max(ahead)  # the first crossing on the way down
        mpip = pivot + radius * (math.cos(phi) * direction + math.sin(phi) * UP)
        bip = surface.closest_point(mpip)
        # the torso has turned with the stick by the time the shoulder reaches the MPIP: the offset in
        # that torso's frame is torso' R(tilt, now - phi)' (bip - mpip)
        offset = torso_rotation.T @ rotated(bip - mpip, tilt_axis, phi - now)
        candidates.append(Candidate(surface, mpip, bip, phi, reach.contains(offset)))
    return candidates


def choose(candidates: list[Candidate]) -> Candidate | None:
    """002's rule: the highest reachable BIP; if none is reachable, the BIP nearest its MPIP."""
    reachable = [c for c in candidates if c.reachable]
    if reachable:
        return max(reachable, key=lambda c: c.bip[2])
    return min(candidates, key=lambda c: float(np.linalg.norm(c.bip - c.mpip)), default=None)
