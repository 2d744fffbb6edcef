"""Pinocchio model of the simulated robot, and the map from MuJoCo's state to Pinocchio's.

Joint order differs (MuJoCo: file order; Pinocchio: branches sorted), so joints are mapped by
name. The free joint differs too: MuJoCo's qpos quaternion is (w, x, y, z) and its linear velocity
is in the world frame; Pinocchio's is (x, y, z, w) and its base velocity is in the base frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np
import pinocchio as pin

from fallbench.robots.description import RobotDescription
from fallbench.robots.mjcf import pinocchio_model as mjcf_pinocchio_model


class SimulatedRobot(Protocol):
    """What the model needs from a simulated robot (the simulator's world satisfies it): the robot
    description, the compiled MuJoCo model (joint addresses, rotor armature) and the actuated joints."""

    robot: RobotDescription
    model: mujoco.MjModel
    joint_names: tuple[str, ...]


@dataclass
class PinocchioModel:
    model: pin.Model
    data: pin.Data
    mj_to_pin_q: np.ndarray  # for each Pinocchio joint q index (after the base): MuJoCo qpos index
    mj_to_pin_v: np.ndarray  # likewise for velocities
    actuated_v: np.ndarray  # Pinocchio v index of each MuJoCo actuator
    frame_ids: dict[str, int] = field(
        default_factory=dict
    )  # name -> id, as getFrameId (first frame of a name), filled on use

    def frame_id(self, name: str) -> int:
        """model.getFrameId(name), cached (the lookup is a search over all frames' names)."""
        frame = self.frame_ids.get(name)
        if frame is None:
            frame = self.frame_ids[name] = self.model.getFrameId(name)
        return frame

    def state(self, qpos_mj: np.ndarray, qvel_mj: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) in Pinocchio's convention from MuJoCo's qpos, qvel."""
        q = np.empty(self.model.nq)
        v = np.empty(self.model.nv)
        q[:3] = qpos_mj[:3]
        q[3:6], q[6] = qpos_mj[4:7], qpos_mj[3]
        rotation = pin.Quaternion(qpos_mj[3], *qpos_mj[4:7]).toRotationMatrix()
        v[:3] = rotation.T @ qvel_mj[:3]
        v[3:6] = qvel_mj[3:6]  # MuJoCo's free-joint angular velocity is already in the body frame
        q[7:] = qpos_mj[self.mj_to_pin_q]
        v[6:] = qvel_mj[self.mj_to_pin_v]
        return q, v


def pinocchio_model(robot: RobotDescription) -> pin.Model:
    """Pinocchio's model of the robot's URDF (with the card's fixes, `urdf_text`) or of its MJCF,
    on a free-flyer root joint."""
    if robot.mjcf_path is not None:
        return mjcf_pinocchio_model(robot.mjcf_path)
    return pin.buildModelFromXML(robot.urdf_text(), pin.JointModelFreeFlyer())


def build_pinocchio(world: SimulatedRobot) -> PinocchioModel:
    """The robot's Pinocchio model, mapped onto the world's MuJoCo model by joint names, with
    MuJoCo's rotor armature."""
    robot = world.robot
    model = pinocchio_model(robot)
    mj = world.model
    q_map, v_map = [], []
    for joint_id in range(2, model.njoints):  # 0 = universe, 1 = free flyer
        name = model.names[joint_id]
        mj_joint = mj.joint(name).id
        q_map.append(mj.jnt_qposadr[mj_joint])
        v_map.append(mj.jnt_dofadr[mj_joint])
        model.armature[model.joints[joint_id].idx_v] = mj.dof_armature[mj.jnt_dofadr[mj_joint]]
    actuated = np.array([model.joints[model.getJointId(name)].idx_v for name in world.joint_names])
    return PinocchioModel(model, model.createData(), np.array(q_map), np.array(v_map), actuated)


_PINOCCHIO: dict[tuple[str, str, str, str], PinocchioModel] = {}
PINOCCHIO_CACHE_SIZE = 16  # models kept; a sweep's worker sees few distinct robots


def pinocchio_for(world: SimulatedRobot) -> PinocchioModel:
    """One Pinocchio model per robot description in this process, keyed by what it is built from:
    the robot's name, card, version and fingerprint (its card and model files). The MuJoCo side it
    maps (joint addresses, rotor armature, actuator order) is the robot's alone, the same in every
    scene of the robot (obstacles and floor add no joint), so every world of a robot shares it,
    whichever object holds the world."""
    robot = world.robot
    key = (robot.name, str(robot.card_path), robot.version, robot.fingerprint)
    model = _PINOCCHIO.get(key)
    if model is None:
        if len(_PINOCCHIO) >= PINOCCHIO_CACHE_SIZE:
            _PINOCCHIO.pop(next(iter(_PINOCCHIO)))
        model = _PINOCCHIO[key] = build_pinocchio(world)
    return model


def select_motors(P: PinocchioModel, bodies: set[str], joint_names: tuple[str, ...]) -> np.ndarray:
    """Actuators (indices in `joint_names`) on the chains between the given bodies and the root (002 eq. 15)."""
    chain: set[int] = set()
    for body in bodies:
        joint = P.model.frames[P.model.getFrameId(body)].parentJoint
        chain.update(j for j in P.model.supports[joint] if j > 1)
    names = {P.model.names[j] for j in chain}
    return np.array([i for i, name in enumerate(joint_names) if name in names], dtype=int)
