"""`fallbench-obs-v1`: the observation a learned fall policy reads and the action it returns.

Observation (float32, length 6 + 3 n, n = the robot's actuated joints in MuJoCo actuator order,
written out per robot in docs/methods/learned.md):

    [ projected gravity (3) | base angular velocity (3) | q - q_default (n) | qd (n) | last action (n) ]

- projected gravity: the unit vector of gravity in the root body's frame (0, 0, -1 upright);
- base angular velocity: the root body's, in its own frame (rad/s; MuJoCo's free-joint velocity);
- q - q_default: joint angles (rad) relative to the robot's `default` posture;
- qd: joint velocities (rad/s);
- last action: the previous action after clipping (0 before the first).

Action (n values, clipped to [-1, 1]): joint position targets as scaled offsets from the default
posture, q_ref = clip(q_default + action_scale a, joint range), qd_ref = 0, held by the robot's
learned-policy PD gains (`RobotDescription.learned_gains`): tau = K (q_ref - q) - B qd, within the
motor's torque limit.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fallbench.robots.description import DEFAULT_POSTURE
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World

OBSERVATION_VERSION = "fallbench-obs-v1"
BASE_TERMS = 6  # projected gravity (3) + base angular velocity (3)


def observation_size(joints: int) -> int:
    """Length of a `fallbench-obs-v1` observation for a robot with `joints` actuated joints."""
    return BASE_TERMS + 3 * joints


@dataclass
class JointLayout:
    """What turns MuJoCo's state into the observation and an action into the servo command."""

    root_body: int  # MuJoCo body id of the root (free joint)
    root_dof: int  # qvel index of the free joint's angular velocity
    qpos_adr: np.ndarray
    qvel_adr: np.ndarray
    q_default: np.ndarray  # rad, the `default` posture per actuated joint
    joint_range: np.ndarray  # rad, (n, 2)
    kp: np.ndarray  # Nm/rad, learned-policy gains
    kd: np.ndarray  # Nms/rad

    @classmethod
    def of(cls, world: World) -> JointLayout:
        robot, model = world.robot, world.model
        posture = robot.postures[DEFAULT_POSTURE]
        gains = np.array([robot.learned_gains(joint) for joint in world.joint_names])
        return cls(
            root_body=world.root_body,
            root_dof=int(model.body_dofadr[world.root_body]) + 3,
            qpos_adr=world.qpos_adr,
            qvel_adr=world.qvel_adr,
            q_default=np.array([posture.get(joint, 0.0) for joint in world.joint_names]),
            joint_range=world.joint_range,
            kp=gains[:, 0].copy(),
            kd=gains[:, 1].copy(),
        )

    @property
    def joints(self) -> int:
        return len(self.qpos_adr)

    @property
    def size(self) -> int:
        return observation_size(self.joints)

    def observe(self, data: mujoco.MjData, last_action: np.ndarray) -> np.ndarray:
        """The `fallbench-obs-v1` vector (float32) of MuJoCo's current state."""
        rotation = data.xmat[self.root_body].reshape(3, 3)
        return np.concatenate(
            [
                -rotation[2],  # R^T (0, 0, -1): gravity's direction in the root frame
                data.qvel[self.root_dof : self.root_dof + 3],
                data.qpos[self.qpos_adr] - self.q_default,
                data.qvel[self.qvel_adr],
                last_action,
            ]
        ).astype(np.float32)

    def command(self, action: np.ndarray, action_scale: float) -> ServoCommand:
        """The servo command of an action already clipped to [-1, 1]."""
        target = np.clip(
            self.q_default + action_scale * action, self.joint_range[:, 0], self.joint_range[:, 1]
        )
        return ServoCommand(self.kp, self.kd, target, np.zeros(self.joints))
