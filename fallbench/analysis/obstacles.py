"""How a fall among objects ended, for every run with obstacles whatever its strategy (so that
`none` compares with a strategy that steers): whether and how close the robot came to an object,
and the actual fall direction against the safe regions about it (`safe_regions.py`, 004).

The fall direction is measured from the CoM's ground projection at the origin (the fall
detection, or the time a strategy gives as `control_trigger_time` among its metrics: when it took
control of the fall) to that at touchdown, or at the first contact with an object if that comes
first: after it the object, not the fall, sets the direction.

The settings (`OutcomeSettings`: the robot's radius and height, the touchdown height, the score's
weight) come from the scenario. The scenario schema has no section of its own for them: they are
read from the keys of the same names under `policy_params.direction`, where the strategy that
plans with the same regions reads them, so that a layout judged for its runs is judged alike for
every other run on it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from fallbench.analysis.safe_regions import (
    angle_between,
    grown_circles,
    needed_deflection,
    safe_regions,
    score,
)
from fallbench.sim.scene import obstacle_geoms

if TYPE_CHECKING:
    from fallbench.scenario import Scenario
    from fallbench.sim.recorder import Recording

CLEARANCE_RANGE = 2.0  # m: distances beyond this are reported as this
ORIGIN_COLUMN = "control_trigger_time"  # s: a strategy's metric, where the fall direction is read from
SETTINGS_SECTION = "direction"  # `policy_params` section holding the settings' keys (see above)


@dataclass(frozen=True)
class OutcomeSettings:
    """How the outcome among objects is judged (004's reading)."""

    robot_radius: float = 0.54  # m: TALOS's widest footprint off the fall line that still touched an object (`fallbench direction radius`, docs/methods/direction.md); 004: half the leg spread (0.45)
    consider_factor: float = 1.5  # objects within this times the robot height count
    robot_height: float = 1.7  # m
    touchdown_fraction: float = 0.35  # CoM height at touchdown / standing CoM height
    w1: float = 0.5  # eq. 4; w2 = 1 - w1

    @classmethod
    def of(cls, scenario: Scenario) -> OutcomeSettings:
        """The scenario's settings: its values of these keys, else the defaults."""
        params = scenario.policy_params.get(SETTINGS_SECTION, {})
        return cls(**{f.name: params[f.name] for f in dataclasses.fields(cls) if f.name in params})

    @property
    def consider_distance(self) -> float:
        """m: objects farther from the origin than this are left out."""
        return self.consider_factor * self.robot_height

    @property
    def w2(self) -> float:
        return 1.0 - self.w1


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


def fall_origin(metrics: dict[str, Any], rec: Recording) -> float | None:
    """s: where the fall direction is read from: the strategy's `control_trigger_time` when its
    metrics give a finite one, else the fall detection."""
    origin = metrics.get(ORIGIN_COLUMN, rec.fall_time)
    return origin if origin == origin else rec.fall_time


def obstacle_contacts(rec: Recording) -> list[np.ndarray]:
    """Per obstacle: whether its contact sensor found a contact, per recorded sample."""
    world = rec.world
    return [world.sensor(rec.sensordata, name)[:, 0] > 0 for name in world.obstacle_sensors]


@dataclass(frozen=True)
class FallReading:
    """The CoM's path at the control rate from the origin on, and where the direction is read."""

    path: np.ndarray  # (samples, 3) m, every `every`-th recorded sample
    every: int
    start: int  # sample of the origin
    end: int  # sample where the direction is read
    why: str  # touchdown | object | run_end

    @property
    def direction(self) -> float:
        """rad in [0, 2 pi)."""
        return _heading(self.path, self.start, self.end)


def fall_reading(
    rec: Recording, origin_time: float, settings: OutcomeSettings, found: list[np.ndarray] | None = None
) -> FallReading:
    """The fall read from `origin_time` (s): the CoM down to the touchdown height, the first contact
    with an object if earlier, else the run's end."""
    scenario = rec.scenario
    found = obstacle_contacts(rec) if found is None else found
    every = max(round(scenario.control_dt / scenario.physics_dt), 1)
    path = com_path(rec, every)
    start = min(int(np.searchsorted(rec.time[::every], origin_time)), len(path) - 1)
    touched = (
        np.flatnonzero(np.any(found, axis=0)) // every if found else np.zeros(0, dtype=int)
    )  # samples at or before a contact
    touched = touched[touched > start]
    end, why = _fall_end(
        path, start, int(touched[0]) if len(touched) else None, settings.touchdown_fraction * path[0, 2]
    )
    return FallReading(path, every, start, end, why)


def actual_fall_direction_deg(rec: Recording, origin_time: float | None) -> float:
    """deg in [0, 360): the actual fall direction from `origin_time` (s; nan without one)."""
    if origin_time is None or not math.isfinite(origin_time):
        return math.nan
    return math.degrees(fall_reading(rec, origin_time, OutcomeSettings.of(rec.scenario)).direction)


def obstacle_metrics(rec: Recording, origin_time: float | None) -> dict[str, Any]:
    """obstacle_hit, obstacle_clearance_at_impact, actual fall direction and whether it lies in a
        safe region, n_safe_regions, the deflection (deg) that would take the actual direction into the
    nearest safe region (0 inside one); origin_time: s, the control (or fall) trigger."""
    settings = OutcomeSettings.of(rec.scenario)
    found = obstacle_contacts(rec)
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
    reading = fall_reading(rec, origin_time, settings, found)
    row["actual_fall_end"] = reading.why
    origin = reading.path[reading.start, :2]
    regions = safe_regions(
        grown_circles(rec.scenario.obstacles, origin, settings.robot_radius, settings.consider_distance),
        origin,
    )
    direction = reading.direction
    row["actual_fall_direction_deg"] = math.degrees(direction)
    row["actual_in_safe_region"] = any(r.contains(direction) for r in regions)
    row["actual_score"] = score(direction, regions, settings.w1, settings.w2)
    row["n_safe_regions"] = len(regions)
    row["needed_deflection_deg"] = math.degrees(needed_deflection(direction, regions))
    row["impact_fall_direction_deg"] = _direction_at_impact(rec, reading, origin_time)
    return row


def _direction_at_impact(rec: Recording, reading: FallReading, origin_time: float) -> float:
    """deg: direction of the CoM's ground projection from the origin to the first impact (the first
    contact of anything but a foot, as `impact_time`); nan without one after the origin. A body that
    lands on its hands and then rolls keeps turning; this reads where it landed."""
    impacts = [event.t for event in rec.impact_events if event.t > origin_time]
    if not impacts:
        return math.nan
    sample = min(int(np.searchsorted(rec.time[:: reading.every], impacts[0])), len(reading.path) - 1)
    return math.degrees(_heading(reading.path, reading.start, sample))


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
    """deg in [0, 180]: the smallest angle between a predicted and an actual fall direction."""
    return math.degrees(angle_between(math.radians(predicted_deg), math.radians(actual_deg)))
