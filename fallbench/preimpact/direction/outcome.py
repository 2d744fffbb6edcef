"""How a fall among objects ended, for every run with obstacles (so that `none` compares with
`direction`): whether and how close the robot came to an object, and the actual fall direction
against the safe regions of 004 (measured from the CoM's ground projection at the control trigger,
or at the fall trigger for strategies without one, to that at touchdown, or at the first contact with
an object if that comes first: after it the object, not the fall, sets the direction)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from fallbench.preimpact.direction.config import DirectionConfig
from fallbench.preimpact.direction.geometry import (
    angle_between,
    grown_circles,
    needed_deflection,
    safe_regions,
)
from fallbench.preimpact.direction.scoring import score
from fallbench.sim.scene import obstacle_geoms

if TYPE_CHECKING:
    from fallbench.sim.recorder import Recording

CLEARANCE_RANGE = 2.0  # m: distances beyond this are reported as this


def com_path(rec: Recording, every: int = 1) -> np.ndarray:
    """(samples, 3) whole-robot CoM, m, world, at every `every`-th recorded sample: the root's
    subtree-CoM sensor, which MuJoCo computes inside each physics step from the state that sample
    recorded (the same numbers as replaying the states through mj_kinematics and mj_comPos, which
    took ~50 ms a run)."""
    return rec.world.sensor(rec.sensordata[::every], "com_pos").copy()


def clearance(rec: Recording, sample: int) -> float:
    """Smallest distance (m) between the robot's geoms and the obstacles at one recorded sample;
    0 or less when touching."""
    model = rec.world.model
    data = mujoco.MjData(model)
    data.qpos[:] = rec.qpos[sample]
    mujoco.mj_kinematics(model, data)
    obstacles = obstacle_geoms(model)
    robot = [g for g in range(model.ngeom) if model.geom_bodyid[g] != 0]
    fromto = np.zeros(6)
    return min(
        (
            mujoco.mj_geomDistance(model, data, g, o, CLEARANCE_RANGE, fromto)
            for o in obstacles
            for g in robot
        ),
        default=math.nan,
    )


def obstacle_metrics(rec: Recording, origin_time: float | None) -> dict[str, Any]:
    """obstacle_hit, obstacle_clearance_at_impact, actual fall direction and whether it lies in a
        safe region, n_safe_regions, the deflection (deg) that would take the actual direction into the
    nearest safe region (0 inside one); origin_time: s, the control (or fall) trigger."""
    world, scenario = rec.world, rec.scenario
    config = DirectionConfig(**scenario.policy_params.get("direction", {}))
    found = [world.sensor(rec.sensordata, name)[:, 0] > 0 for name in world.obstacle_sensors]
    row: dict[str, Any] = {"obstacle_hit": bool(any(f.any() for f in found))}
    impact = rec.impact_events[0].t if rec.impact_events else rec.time[-1]
    row["obstacle_clearance_at_impact"] = clearance(
        rec, min(int(np.searchsorted(rec.time, impact)), len(rec.time) - 1)
    )
    nan = {
        "actual_fall_direction_deg": math.nan,
        "actual_in_safe_region": False,
        "actual_score": math.nan,
        "n_safe_regions": -1,
        "actual_fall_end": "",
        "needed_deflection_deg": math.nan,
        "impact_fall_direction_deg": math.nan,
    }
    if origin_time is None or not math.isfinite(origin_time):
        return row | nan
    every = max(round(scenario.control_dt / scenario.physics_dt), 1)
    path = com_path(rec, every)
    start = min(int(np.searchsorted(rec.time[::every], origin_time)), len(path) - 1)
    touched = (
        np.flatnonzero(np.any(found, axis=0)) // every if found else np.zeros(0, dtype=int)
    )  # samples at or before a contact
    touched = touched[touched > start]
    end, row["actual_fall_end"] = _fall_end(
        path, start, int(touched[0]) if len(touched) else None, config.touchdown_fraction * path[0, 2]
    )
    origin = path[start, :2]
    regions = safe_regions(
        grown_circles(
            scenario.obstacles, origin, config.robot_radius, config.consider_factor * config.robot_height
        ),
        origin,
    )
    direction = _heading(path, start, end)
    row["actual_fall_direction_deg"] = math.degrees(direction)
    row["actual_in_safe_region"] = any(r.contains(direction) for r in regions)
    row["actual_score"] = score(direction, regions, config.w1, config.w2)
    row["n_safe_regions"] = len(regions)
    row["needed_deflection_deg"] = math.degrees(needed_deflection(direction, regions))
    row["impact_fall_direction_deg"] = _direction_at_impact(rec, path, start, every, origin_time)
    return row


def _direction_at_impact(
    rec: Recording, path: np.ndarray, start: int, every: int, origin_time: float
) -> float:
    """deg: direction of the CoM's ground projection from the origin to the first impact (the first
    contact of anything but a foot, as `impact_time`); nan without one after the origin. A body that
    lands on its hands and then rolls keeps turning; this reads where it landed."""
    impacts = [event.t for event in rec.impact_events if event.t > origin_time]
    if not impacts:
        return math.nan
    sample = min(int(np.searchsorted(rec.time[::every], impacts[0])), len(path) - 1)
    return math.degrees(_heading(path, start, sample))


def _heading(path: np.ndarray, start: int, end: int) -> float:
    """rad in [0, 2 pi): direction of the CoM's ground projection from sample `start` to `end`."""
    delta = path[end, :2] - path[start, :2]
    return math.atan2(delta[1], delta[0]) % (2 * math.pi)


def _fall_end(
    path: np.ndarray, start: int, first_touch: int | None, touchdown_height: float
) -> tuple[int, str]:
    """(sample, why) where the fall direction is read: the CoM down to `touchdown_height` ("touchdown"),
    or the first contact with an object (sample `first_touch`) if earlier ("object": a fall deflected
    by an object is not a fall in the direction it ends in), else the run's last sample ("run_end",
    e.g. the robot still upright)."""
    low = np.flatnonzero(path[start:, 2] <= touchdown_height)
    ends = [(start + int(low[0]), "touchdown")] if len(low) else []
    ends += [(first_touch, "object")] if first_touch is not None else []
    return min(ends, key=lambda end: end[0]) if ends else (len(path) - 1, "run_end")


def direction_error_deg(predicted_deg: float, actual_deg: float) -> float:
    return math.degrees(angle_between(math.radians(predicted_deg), math.radians(actual_deg)))
