"""The robot's kinematics at one measured state, computed once per control step.

`RobotState.measure` runs Pinocchio's kinematics at (q, v) with zero joint accelerations, so that
every frame's classical acceleration is its drift J_dot q_dot; then the CoM terms and the contact
points' kinematics. Tasks and limits take a `RobotState`, so that "the kinematics were computed" is
a type rather than a precondition in a docstring. Pinocchio coordinates and velocity convention.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics import kernels
from fallbench.dynamics.contacts import NO_CONTACTS, ContactKinematics, ContactSet
from fallbench.dynamics.model import PinocchioModel

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class RobotState:
    """Kinematics at (q, v). The state reads its robot's Pinocchio data: it is valid until that data
    is computed at another (q, v) (the next `measure` of the same robot, one per control step)."""

    robot: PinocchioModel
    q: np.ndarray  # (nq,) Pinocchio configuration
    v: np.ndarray  # (nv,) Pinocchio velocity
    com: np.ndarray  # m, world
    com_velocity: np.ndarray  # m/s
    com_drift: np.ndarray  # m/s^2, J_com_dot v
    com_jacobian: np.ndarray  # (3, nv)
    contacts: ContactKinematics  # of the points measured with the state (none by default)

    @classmethod
    def measure(
        cls, robot: PinocchioModel, q: np.ndarray, v: np.ndarray, points: ContactSet = NO_CONTACTS
    ) -> RobotState:
        """One kinematic pass at (q, v, q_ddot = 0); the Jacobians, frames, CoM and contact points read it."""
        model, data = robot.model, robot.data
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        pin.computeJointJacobians(model, data)
        pin.updateFramePlacements(model, data)
        contacts = _contact_kinematics(robot, v, points)
        pin.centerOfMass(model, data, pin.KinematicLevel.ACCELERATION, True)
        com, com_velocity, com_drift = data.com[0].copy(), data.vcom[0].copy(), data.acom[0].copy()
        com_jacobian = pin.jacobianCenterOfMass(model, data, False).copy()  # subtree CoMs from centerOfMass
        return cls(robot, q, v, com, com_velocity, com_drift, com_jacobian, contacts)

    @property
    def model(self) -> pin.Model:
        return self.robot.model

    @property
    def data(self) -> pin.Data:
        """Pinocchio's data holding this state's kinematics (joint and frame placements oMi, oMf, J)."""
        return self.robot.data

    def frame_placement(self, frame: int) -> pin.SE3:
        """World placement of a frame (Pinocchio frame id)."""
        return self.robot.data.oMf[frame]

    def frame_jacobian(self, frame: int) -> np.ndarray:
        """(6, nv): the frame's (linear, angular) velocity per joint velocity, world-aligned axes at its origin."""
        return pin.getFrameJacobian(self.robot.model, self.robot.data, frame, LWA)

    def frame_velocity(self, frame: int) -> pin.Motion:
        """The frame's velocity (m/s, rad/s), world-aligned axes at its origin."""
        return pin.getFrameVelocity(self.robot.model, self.robot.data, frame, LWA)

    def frame_drift(self, frame: int) -> pin.Motion:
        """The frame's classical acceleration at q_ddot = 0 (m/s^2, rad/s^2): J_dot q_dot, world-aligned."""
        return pin.getFrameClassicalAcceleration(self.robot.model, self.robot.data, frame, LWA)

    def points_kinematics(
        self, frames: list[int], body_of: np.ndarray, offsets: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians (m, 3, nv) and drifts J_dot q_dot (m, 3) of m points on several bodies: point i is
        fixed in the body of frame frames[body_of[i]], at world-frame offset offsets[i] (m) from its
        origin. One frame Jacobian, velocity and drift per body, then all points in one kernel."""
        return _points_kinematics(self.robot.model, self.robot.data, frames, body_of, offsets)


def _points_kinematics(
    model: pin.Model, data: pin.Data, frames: list[int], body_of: np.ndarray, offsets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """`RobotState.points_kinematics` on data that `measure` has filled."""
    J6 = np.array([pin.getFrameJacobian(model, data, frame, LWA) for frame in frames])  # (bodies, 6, nv)
    omega = np.array([pin.getFrameVelocity(model, data, frame, LWA).angular for frame in frames])
    acceleration = np.array(
        [pin.getFrameClassicalAcceleration(model, data, frame, LWA).vector for frame in frames]
    )
    return kernels.points_kinematics(
        J6, omega, acceleration, body_of, np.ascontiguousarray(offsets, dtype=float)
    )


def _contact_kinematics(robot: PinocchioModel, v: np.ndarray, contacts: ContactSet) -> ContactKinematics:
    """Point Jacobians, drifts and velocities of the contact points, one frame computation per
    contact body, on data that `measure` has filled."""
    model, data, n = robot.model, robot.data, len(contacts)
    if not n:
        empty = np.zeros(0)
        return ContactKinematics(
            np.zeros((0, model.nv)),
            empty,
            empty,
            np.zeros((0, 3)),
            np.zeros(0, dtype=int),
            np.zeros((0, model.nv)),
            empty,
            np.zeros((model.nv, 0)),
        )
    bodies = list(dict.fromkeys(contacts.bodies))  # first-seen order
    frames = [robot.frame_id(body) for body in bodies]
    body_of = np.array([bodies.index(body) for body in contacts.bodies])
    origins = np.array([data.oMf[frame].translation for frame in frames])
    jacobian, drift = _points_kinematics(model, data, frames, body_of, contacts.positions - origins[body_of])
    normals = contacts.normals
    normal_jacobian, normal_drift, velocity = kernels.normal_motion(jacobian, drift, normals, v)
    jacobian = jacobian.reshape(3 * n, model.nv)
    forces = kernels.force_map(jacobian, contacts.generators)
    return ContactKinematics(
        jacobian, drift.reshape(3 * n), velocity, normals, body_of, normal_jacobian, normal_drift, forces
    )
