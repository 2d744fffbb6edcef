"""Contact points of the robot with the environment, as the adaptive-gain QP needs them.

The points come from the simulator's contact list (the robot's contact candidates would do on
hardware). For each: position, normal pointing into the robot, a 4-generator linearized friction
cone, the point Jacobian and drift J_dot q_dot from Pinocchio, and the point's velocity.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from fallbench.dynamics.model import PinocchioModel
from fallbench.dynamics.tasks.body_point import points_kinematics


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


def friction_generators(normal: np.ndarray, tangent1: np.ndarray, tangent2: np.ndarray, mu: float) -> np.ndarray:
    edges = np.stack([normal + mu * tangent1, normal - mu * tangent1, normal + mu * tangent2, normal - mu * tangent2], axis=1)
    return edges / np.linalg.norm(edges, axis=0)


def cone_matrix(points: list[ContactPoint]) -> np.ndarray:
    """G (3 n, 4 n): block diagonal of the points' friction-cone generators; forces = G lambda."""
    G = np.zeros((3 * len(points), 4 * len(points)))
    for i, point in enumerate(points):
        G[3 * i : 3 * i + 3, 4 * i : 4 * i + 4] = point.generators
    return G


def normal_matrix(points: list[ContactPoint]) -> np.ndarray:
    """N (n, 3 n): row i picks point i's normal component out of stacked 3D vectors."""
    N = np.zeros((len(points), 3 * len(points)))
    for i, point in enumerate(points):
        N[i, 3 * i : 3 * i + 3] = point.normal
    return N


def environment_contacts(model: mujoco.MjModel, data: mujoco.MjData, friction: float) -> list[ContactPoint]:
    """Contacts between a robot body and the world's static geoms (floor, obstacles)."""
    points = []
    for i in range(data.ncon):
        contact = data.contact[i]
        body1, body2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
        if (body1 == 0) == (body2 == 0):  # robot self-contact, or world-world
            continue
        frame = contact.frame.reshape(3, 3)
        sign = 1.0 if body1 == 0 else -1.0  # MuJoCo's normal points from geom1 to geom2
        robot_body = body2 if body1 == 0 else body1
        normal = sign * frame[0]
        points.append(ContactPoint(model.body(robot_body).name, contact.pos.copy(), normal,
                                   friction_generators(normal, frame[1], frame[2], friction), i, sign))
    return points


def contact_kinematics(P: PinocchioModel, v: np.ndarray, points: list[ContactPoint]) -> ContactKinematics:
    """Point Jacobians, drifts and velocities, one frame computation per contact body; needs
    forwardKinematics(q, v, 0) and computeJointJacobians(q) done on P.data."""
    model, data = P.model, P.data
    n = len(points)
    jacobian = np.zeros((n, 3, model.nv))
    drift = np.zeros((n, 3))
    for body in dict.fromkeys(p.body for p in points):  # first-seen order
        rows = [i for i, p in enumerate(points) if p.body == body]
        origin = data.oMf[model.getFrameId(body)].translation
        offsets = np.array([points[i].position for i in rows]) - origin
        jacobian[rows], drift[rows] = points_kinematics(model, data, body, offsets)
    jacobian = jacobian.reshape(3 * n, model.nv)
    return ContactKinematics(jacobian, drift.reshape(3 * n), jacobian @ v)
