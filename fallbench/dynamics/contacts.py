"""Contact points of the robot with the environment, as the adaptive-gain QP needs them.

The points come from the simulator's contact list (the robot's contact candidates would do on
hardware). For each: position, normal pointing into the robot, a 4-generator linearized friction
cone, the point Jacobian and drift J_dot q_dot from Pinocchio, and the point's velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from fallbench.dynamics import kernels
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.tasks.body_point import bodies_points_kinematics


@dataclass
class ContactPoint:
    body: str
    position: np.ndarray  # m, world
    normal: np.ndarray  # unit, world, from the environment into the robot
    generators: np.ndarray  # (3, 4) unit friction-cone edges: force = generators @ lambda
    index: int = -1  # the contact's index in MjData.contact (-1: not from the simulator)
    sign: float = 1.0  # +1 when the robot is MuJoCo's geom2 (the contact frame's normal points into it), else -1


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


def friction_generators(normal: np.ndarray, tangent1: np.ndarray, tangent2: np.ndarray, mu: float) -> np.ndarray:
    """(3, 4) unit edges n +- mu t of the linearized cone about `normal`; with (k, 3) arguments, (k, 3, 4).
    (n, t1, t2) orthonormal, as MuJoCo's contact frame: every edge's length is then sqrt(1 + mu^2)."""
    tangents = np.stack([tangent1, -tangent1, tangent2, -tangent2], axis=-1)
    return (normal[..., None] + mu * tangents) / math.sqrt(1.0 + mu * mu)


def environment_contacts(model: mujoco.MjModel, data: mujoco.MjData, friction: float) -> list[ContactPoint]:
    """Contacts between a robot body and the world's static geoms (floor, obstacles)."""
    contacts = data.contact
    bodies = model.geom_bodyid[contacts.geom[: data.ncon]]  # (ncon, 2): geom1's and geom2's bodies
    index = np.flatnonzero((bodies[:, 0] == 0) != (bodies[:, 1] == 0))  # not self-contact, not world-world
    if not len(index):
        return []
    frames = contacts.frame[index].reshape(-1, 3, 3)
    signs = np.where(bodies[index, 0] == 0, 1.0, -1.0)  # MuJoCo's normal points from geom1 to geom2
    normals = signs[:, None] * frames[:, 0]
    generators = friction_generators(normals, frames[:, 1], frames[:, 2], friction)
    robot_bodies = np.where(bodies[index, 0] == 0, bodies[index, 1], bodies[index, 0])
    positions = contacts.pos[index]
    return [ContactPoint(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body), positions[k], normals[k], generators[k], int(i), float(signs[k]))
            for k, (i, body) in enumerate(zip(index, robot_bodies))]


def contact_kinematics(P: PinocchioModel, v: np.ndarray, points: list[ContactPoint]) -> ContactKinematics:
    """Point Jacobians, drifts and velocities, one frame computation per contact body; needs
    forwardKinematics(q, v, 0) and computeJointJacobians(q) done on P.data."""
    model, data, n = P.model, P.data, len(points)
    if not points:
        empty = np.zeros(0)
        return ContactKinematics(np.zeros((0, model.nv)), empty, empty, np.zeros((0, 3)), np.zeros(0, dtype=int), np.zeros((0, model.nv)), empty,
                                 np.zeros((model.nv, 0)))
    bodies = list(dict.fromkeys(p.body for p in points))  # first-seen order
    frames = [P.frame_id(body) for body in bodies]
    body_of = np.array([bodies.index(p.body) for p in points])
    origins = np.array([data.oMf[frame].translation for frame in frames])
    offsets = np.array([p.position for p in points]) - origins[body_of]
    jacobian, drift = bodies_points_kinematics(model, data, frames, body_of, offsets)
    normals = np.array([p.normal for p in points])
    normal_jacobian, normal_drift = (normals[:, None, :] @ jacobian)[:, 0], (normals * drift).sum(axis=1)
    jacobian = jacobian.reshape(3 * n, model.nv)
    forces = kernels.force_map(jacobian, np.array([p.generators for p in points]))
    return ContactKinematics(jacobian, drift.reshape(3 * n), jacobian @ v, normals, body_of, normal_jacobian, normal_drift, forces)
