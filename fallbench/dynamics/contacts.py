"""Contact points of the robot with the environment, as the adaptive-gain QP needs them.

The points come from the simulator's contact list (the robot's contact candidates would do on
hardware). For each: position, normal pointing into the robot and a 4-generator linearized friction
cone; `RobotState.measure` adds their kinematics (`ContactKinematics`: point Jacobians, drifts
J_dot q_dot and velocities from Pinocchio).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass
class ContactSet:
    """The robot's contact points with the environment at one instant, one row per point."""

    bodies: list[str]  # the robot body of each point
    positions: np.ndarray  # (n, 3) m, world
    normals: np.ndarray  # (n, 3) unit, world, from the environment into the robot
    generators: np.ndarray  # (n, 3, 4) unit friction-cone edges: point i's force = generators[i] @ lambda_i
    index: np.ndarray  # (n,) each contact's index in MjData.contact (-1: not from the simulator)
    sign: (
        np.ndarray
    )  # (n,) +1 when the robot is MuJoCo's geom2 (the contact frame's normal points into it), else -1

    def __len__(self) -> int:
        return len(self.bodies)

    @classmethod
    def of_points(
        cls, bodies: list[str], positions: np.ndarray, normals: np.ndarray, generators: np.ndarray
    ) -> ContactSet:
        """Points not from the simulator (index -1)."""
        return cls(
            list(bodies),
            np.asarray(positions, dtype=float).reshape(-1, 3),
            np.asarray(normals, dtype=float).reshape(-1, 3),
            np.asarray(generators, dtype=float).reshape(-1, 3, 4),
            np.full(len(bodies), -1),
            np.ones(len(bodies)),
        )


NO_CONTACTS = ContactSet.of_points([], np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 4)))


@dataclass
class ContactKinematics:
    jacobian: np.ndarray  # (3 n, nv) point Jacobians, Pinocchio velocity coordinates
    drift: np.ndarray  # (3 n,) J_dot q_dot, m/s^2
    velocity: np.ndarray  # (3 n,) m/s
    normals: np.ndarray  # (n, 3) unit, world, into the robot
    body_of: np.ndarray  # (n,) index of each point's body, bodies numbered in first-seen order
    normal_jacobian: np.ndarray  # (n, nv) n'J of each point
    normal_drift: np.ndarray  # (n,) n' J_dot q_dot, m/s^2
    force_map: np.ndarray  # (nv, 4 n) J'G: generalized forces (N, Nm) per friction-cone coefficient (N)

    def __len__(self) -> int:
        return len(self.normals)


_FIRST, _SECOND = np.array([1.0, -1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, -1.0])  # edges: +-t1, then +-t2


def friction_generators(
    normal: np.ndarray, tangent1: np.ndarray, tangent2: np.ndarray, mu: float
) -> np.ndarray:
    """(3, 4) unit edges n + mu t1, n - mu t1, n + mu t2, n - mu t2 of the linearized cone about `normal`;
    with (k, 3) arguments, (k, 3, 4). (n, t1, t2) orthonormal, as MuJoCo's contact frame: every edge's
    length is then sqrt(1 + mu^2)."""
    tangents = tangent1[..., None] * _FIRST + tangent2[..., None] * _SECOND  # exact: each entry is +-t or 0
    return (normal[..., None] + mu * tangents) / math.sqrt(1.0 + mu * mu)


def environment_contacts(model: mujoco.MjModel, data: mujoco.MjData, friction: float) -> ContactSet:
    """Contacts between a robot body and the world's static geoms (floor, obstacles)."""
    contacts = data.contact
    bodies = model.geom_bodyid[contacts.geom[: data.ncon]]  # (ncon, 2): geom1's and geom2's bodies
    world = bodies == 0
    index = np.flatnonzero(world[:, 0] != world[:, 1])  # not self-contact, not world-world
    if not len(index):
        return NO_CONTACTS
    frames = contacts.frame[index].reshape(-1, 3, 3)
    signs = np.where(world[index, 0], 1.0, -1.0)  # MuJoCo's normal points from geom1 to geom2
    normals = signs[:, None] * frames[:, 0]
    generators = friction_generators(normals, frames[:, 1], frames[:, 2], friction)
    robot_bodies = bodies[index].sum(axis=1).tolist()  # the other body is the world's, id 0
    names = {body: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) for body in set(robot_bodies)}
    return ContactSet(
        [names[body] for body in robot_bodies], contacts.pos[index], normals, generators, index, signs
    )
