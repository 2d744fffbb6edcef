"""The desired fall direction theta_d of 004 Sec. IV-A-1: the bisector of the chosen direction's
safe region. The regions and the scores of eqs. 2-4 are `fallbench.analysis.safe_regions`'s: the
outcome of every run among objects is judged by them too."""

from __future__ import annotations

from fallbench.analysis.safe_regions import SafeRegion, region_of


def desired_direction(angle: float, regions: list[SafeRegion]) -> float | None:
    """theta_d: the bisector of the region containing the chosen fall direction, or of the nearest one."""
    region = region_of(angle, regions)
    return None if region is None else region.bisector
