"""Objects as grown circles, the cones they block, the safe fall regions between them, and the
score of a fall direction against them (004 Sec. III-A, III-C, IV-A-1, eqs. 1-4): what the outcome
of every run among objects is judged by (`fallbench.analysis.obstacles`), and what the `direction`
strategy plans with.

Planning is planar, in polar coordinates about the robot's CoM ground projection; angles are in
radians, 0 = world x, counter-clockwise. Each object is its circumscribing vertical cylinder (a
circle on the ground), grown by the robot's radius (half its maximum leg spread) so that the robot
becomes a point. Objects farther than `consider_distance` are ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.scenario import Box, Cylinder

TWO_PI = 2.0 * math.pi


def wrap(angle: float) -> float:
    """An angle in [0, 2 pi)."""
    return angle % TWO_PI


def angle_between(a: float, b: float) -> float:
    """Unsigned smallest angle between two directions, in [0, pi]."""
    d = abs(a - b) % TWO_PI
    return min(d, TWO_PI - d)


@dataclass(frozen=True)
class Circle:
    centre: np.ndarray  # m, (2,) world
    radius: float  # m


@dataclass(frozen=True)
class Cone:
    """Directions from the origin blocked by one grown circle."""

    centre: float  # rad
    half_angle: float  # rad: asin(R / d), or pi/2 when the origin is inside the circle


@dataclass(frozen=True)
class SafeRegion:
    """A free cone SF_j: directions from `start` counter-clockwise over `width` (rad)."""

    start: float  # rad, in [0, 2 pi)
    width: float  # rad, Delta theta_fj

    @property
    def bisector(self) -> float:
        """theta^b_fj, rad."""
        return wrap(self.start + self.width / 2)

    def contains(self, angle: float) -> bool:
        return wrap(angle - self.start) <= self.width

    def distance(self, angle: float) -> float:
        """Angle (rad) from a direction to the region's nearer boundary, 0 inside."""
        if self.contains(angle):
            return 0.0
        return min(angle_between(angle, self.start), angle_between(angle, self.start + self.width))


def object_circle(obstacle: Box | Cylinder) -> Circle:
    """The circumscribing circle of an obstacle's ground footprint."""
    centre = np.array(obstacle.pos[:2], dtype=float)
    if isinstance(obstacle, Cylinder):
        return Circle(centre, obstacle.radius)
    return Circle(centre, 0.5 * math.hypot(obstacle.size[0], obstacle.size[1]))


def grown_circles(
    obstacles: list[Box | Cylinder], origin: np.ndarray, robot_radius: float, consider_distance: float
) -> list[Circle]:
    """Objects within `consider_distance` (m, centre to origin) grown by the robot radius."""
    circles = [object_circle(o) for o in obstacles]
    return [
        Circle(c.centre, c.radius + robot_radius)
        for c in circles
        if float(np.linalg.norm(c.centre - origin[:2])) <= consider_distance
    ]


def blocked_cone(circle: Circle, origin: np.ndarray) -> Cone:
    offset = circle.centre - origin[:2]
    distance = float(np.linalg.norm(offset))
    centre = wrap(math.atan2(offset[1], offset[0]))
    half = math.pi / 2 if distance <= circle.radius else math.asin(circle.radius / distance)
    return Cone(centre, half)


def safe_regions(circles: list[Circle], origin: np.ndarray, margin: float = 0.0) -> list[SafeRegion]:
    """The free cones between the blocked ones, overlapping cones merged (eq. 1 counts
    n_obj - n_int regions, which is wrong when three or more cones overlap; merging is exact).
    No object: one region, the whole circle. Everything blocked: no region. `margin` (rad) widens
    every blocked cone on both sides (0 in 004)."""
    if not circles:
        return [SafeRegion(0.0, TWO_PI)]
    cones = [blocked_cone(c, origin) for c in circles]
    half_angles = [min(c.half_angle + margin, math.pi) for c in cones]
    intervals = sorted((wrap(c.centre - half), 2 * half) for c, half in zip(cones, half_angles))
    # Unroll onto a line starting at the first blocked interval and merge.
    base = intervals[0][0]
    merged: list[list[float]] = []
    for start, width in intervals:
        lo = wrap(start - base)
        hi = lo + width
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    while (
        len(merged) > 1 and merged[-1][1] - TWO_PI >= merged[0][0]
    ):  # the last interval wraps onto the first
        first = merged.pop(0)
        merged[-1][1] = max(merged[-1][1], first[1] + TWO_PI)
    if merged[-1][1] - merged[0][0] >= TWO_PI:
        return []
    regions = []
    for k, (_, hi) in enumerate(merged):
        next_lo = merged[k + 1][0] if k + 1 < len(merged) else merged[0][0] + TWO_PI
        if next_lo > hi:
            regions.append(SafeRegion(wrap(base + hi), next_lo - hi))
    return regions


def signed_turn(a: float, b: float) -> float:
    """Smallest rotation (rad, + counter-clockwise) taking direction a to direction b, in (-pi, pi]."""
    turn = wrap(b - a)
    return turn - TWO_PI if turn > math.pi else turn


def needed_deflection(angle: float, regions: list[SafeRegion]) -> float:
    """The smallest rotation (rad, + counter-clockwise) that takes a fall direction into a safe
    region: 0 inside one, nan when none is free (the deflection a hit needs, item 5 of the review)."""
    if not regions:
        return math.nan
    if any(r.contains(angle) for r in regions):
        return 0.0
    turns = [signed_turn(angle, edge) for r in regions for edge in (r.start, r.start + r.width)]
    return min(turns, key=abs)


# ---------------------------------------------------------------- scores (004 Sec. IV-A-1, eqs. 2-4)
# A direction in a safe region scores in [0, 1] (0 on the widest region's bisector), a direction
# outside every region more than 1; lower is safer.


def region_of(angle: float, regions: list[SafeRegion]) -> SafeRegion | None:
    """The safe region containing a direction, else the nearest one (theta -> SF_j*); None if there is none."""
    if not regions:
        return None
    inside = [r for r in regions if r.contains(angle)]
    return inside[0] if inside else min(regions, key=lambda r: r.distance(angle))


def score(angle: float, regions: list[SafeRegion], w1: float = 0.5, w2: float = 0.5) -> float:
    """s = w1 s1 + w2 s2 (eq. 4), s1 by eq. 2, s2 by eq. 3; infinite when no region is free."""
    region = region_of(angle, regions)
    if region is None:
        return math.inf
    widest = max(r.width for r in regions)
    inside = region.contains(angle)
    s1 = 1.0 - region.width / widest if inside else 1.0
    s2 = 2.0 * angle_between(angle, region.bisector) / region.width
    return w1 * s1 + w2 * s2
