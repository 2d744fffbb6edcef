"""What a control step reads of the robot for the fall detectors and the impacts: the torso frame,
the accelerometer, the CoM and its velocity, the footprints of the feet in contact and the capture
point's distance to their polygon (`DetectorInputs`); and a foot's whole chain, so that an ankle
link touching while its sole is on the floor counts as the foot rolling, not as an impact."""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from fallbench.sim.events import capture_point_distance
from fallbench.sim.support import FootSupport
from fallbench.sim.world import World


class DetectorInputs(NamedTuple):
    """A control step's inputs to the fall detectors (`Sensing.detector_inputs`)."""

    found: np.ndarray  # per contact body: touching since the last control step
    torso: np.ndarray  # torso frame in the world: columns forward, left, up
    imu_acc: np.ndarray  # m/s^2, accelerometer (gravity included)
    com: np.ndarray  # m
    com_velocity: np.ndarray  # m/s
    support: np.ndarray  # (n, 2) m, ground points of the feet in contact
    distance: float  # m, the capture point's signed distance to their polygon (NaN: no support)


class Sensing:
    """The fall detectors' inputs of one world, read at a control step."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.support = FootSupport(world)
        self.torso_rotation = np.zeros(9)
        self.foot_chains = foot_chains(world)

    def detector_inputs(
        self, data: mujoco.MjData, sensor_row: np.ndarray, found: np.ndarray
    ) -> DetectorInputs:
        """The contact sensors (`found`, per contact body), torso frame, accelerometer, CoM position
        and velocity (from the last physics step's sensor row), the ground points of the feet in
        contact and the capture point's distance to their polygon."""
        world = self.world
        mujoco.mju_copy(self.torso_rotation, data.xmat[world.torso_body])
        com, com_velocity = world.sensor(sensor_row, "com_pos"), world.sensor(sensor_row, "com_vel")
        support = self.support.points(data, found)
        return DetectorInputs(
            found,
            world.robot.torso_frame(self.torso_rotation.reshape(3, 3)),
            world.sensor(sensor_row, "imu_acc"),
            com,
            com_velocity,
            support,
            capture_point_distance(com, com_velocity, support),  # once, for the detector and the log
        )

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
