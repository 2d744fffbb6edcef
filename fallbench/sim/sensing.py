"""What a control step reads of the robot for the fall detectors and the impacts: the torso's tilt,
the accelerometer's norm, the footprints of the feet in contact and the capture point's distance to
their polygon (`DetectorInputs`); and a foot's whole chain, so that an ankle link touching while its
sole is on the floor counts as the foot rolling, not as an impact.

A control step runs between physics steps that leave NumPy's code and data out of the caches: its
first NumPy calls cost several times what they cost in a loop of their own. The inputs are read
with few of them, as Python numbers where that gives the same bits.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import mujoco
import numpy as np

from fallbench.sim.events import acc_norm, support_distance, tilt_deg, tilt_from_cosine
from fallbench.sim.support import FootSupport
from fallbench.sim.world import World


class DetectorInputs(NamedTuple):
    """A control step's inputs to the fall detectors (`Sensing.detector_inputs`)."""

    found: np.ndarray  # per contact body: touching since the last control step
    support: np.ndarray  # (n, 2) m, ground points of the feet in contact
    distance: float  # m, the capture point's signed distance to their polygon (NaN: no support)
    tilt: float  # deg, the torso's tilt (`events.tilt_deg` of its frame, `RobotDescription.torso_frame`)
    acc: float  # m/s^2, the accelerometer's norm (`events.acc_norm`, gravity included)


class Sensing:
    """The fall detectors' inputs of one world, read at a control step."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.support = FootSupport(world)
        self.foot_chains = foot_chains(world)
        # read once, not per control step: the torso frame's axes, as `torso_frame` builds them,
        # the sensors' columns
        self.axes = np.array(world.robot.torso_axes).T
        self.up = up_column(world.robot.torso_axes)
        self.com, self.com_velocity, self.imu_acc = (
            slice(world.sensors[name].start, world.sensors[name].start + world.sensors[name].size)
            for name in ("com_pos", "com_vel", "imu_acc")
        )

    def detector_inputs(
        self, data: mujoco.MjData, sensor_row: np.ndarray, found: np.ndarray
    ) -> DetectorInputs:
        """The contact sensors (`found`, per contact body), the torso's tilt, the accelerometer's
        norm, the CoM position and velocity (from the last physics step's sensor row), the ground
        points of the feet in contact and the capture point's distance to their polygon."""
        support = self.support.points(data, found)
        # each signal once, for the detectors and the log; the distance as `capture_point_distance` gives it
        distance = (
            support_distance(
                sensor_row[self.com].tolist(), sensor_row[self.com_velocity].tolist(), support.tolist()
            )
            if len(support)
            else math.nan
        )
        return DetectorInputs(found, support, distance, self.tilt(data), acc_norm(sensor_row[self.imu_acc]))

    def tilt(self, data: mujoco.MjData) -> float:
        """deg: `tilt_deg` of the torso frame. With the torso's up axis one of its body's axes
        (`up_column`), the frame's (2, 2) entry is that entry of the body's rotation (its sign
        flipped for a negative axis): the matrix product adds it to products with zero, exactly."""
        if self.up is None:
            return tilt_deg(data.xmat[self.world.torso_body].reshape(3, 3) @ self.axes)
        index, sign = self.up
        return tilt_from_cosine(sign * float(data.xmat[self.world.torso_body, index]))

    def whole_feet(self, touching: np.ndarray) -> np.ndarray:
        """The touching bodies and, for each foot among them, the foot's other bodies up its chain:
        an ankle link that touches while its sole is on the floor is the foot rolling, not an impact."""
        whole = touching.copy()
        for body, foot in self.foot_chains.items():
            whole[foot] |= touching[body]
        return whole


def foot_chains(world: World) -> dict[int, list[int]]:
    """Contact body index of each feet-group body -> the indices of the feet-group bodies above it."""
    feet = [
        world.contact_bodies.index(b)
        for b in world.robot.body_groups.get("feet", ())
        if b in world.contact_bodies
    ]
    body_ids = {world.model.body(world.contact_bodies[i]).id: i for i in feet}
    chains = {}
    for index in feet:
        above, parent = [], world.model.body_parentid[world.model.body(world.contact_bodies[index]).id]
        while parent > 0:
            if parent in body_ids:
                above.append(body_ids[parent])
            parent = world.model.body_parentid[parent]
        chains[index] = above
    return chains


def up_column(axes: tuple[tuple[float, float, float], ...]) -> tuple[int, float] | None:
    """(index in a row-major rotation's 9 entries, sign) of the world-z component of the torso's up
    axis when that axis (`axes[2]`, in the torso body's frame) is one of the body's axes or its
    opposite; None for any other axis."""
    up = [float(value) for value in axes[2]]
    nonzero = [k for k, value in enumerate(up) if value != 0.0]
    if len(nonzero) != 1 or abs(up[nonzero[0]]) != 1.0:
        return None
    return 6 + nonzero[0], up[nonzero[0]]
