"""Scores of fall directions (004 Sec. IV-A-1, eqs. 2-4) and the desired direction.

A direction in a safe region scores in [0, 1] (0 on the widest region's bisector), a direction
outside every region more than 1; lower is safer.
"""

from __future__ import annotations

import math

from fallbench.preimpact.direction.geometry import SafeRegion, angle_between


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


def desired_direction(angle: float, regions: list[SafeRegion]) -> float | None:
    """theta_d: the bisector of the region containing the chosen fall direction, or of the nearest one."""
    region = region_of(angle, regions)
    return None if region is None else region.bisector
