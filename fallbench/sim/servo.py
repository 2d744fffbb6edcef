"""The joint servo: a PD inside every physics step, as MuJoCo position actuators.

force = K (q_ref - q) + B (qd_ref - qd), clamped at the motor's torque limit by the actuator's
forcerange. MuJoCo computes it at every physics step (and treats the damping implicitly), which is
what keeps stiff gains stable; a PD computed once per 5 ms control step and held is not (measured
with TALOS's leg gains 2000/20: the ankles chatter at up to 84 rad/s during free fall). The controller rewrites K, B, q_ref and qd_ref once per control step, into the run's own model
(`sim/world.py:build_world`: a copy of the cached scene's, which no run writes).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass
class ServoCommand:
    """Per actuated joint: stiffness K (Nm/rad), damping B (Nms/rad), references (rad, rad/s)."""

    kp: np.ndarray
    kd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray


def write_servo(model: mujoco.MjModel, data: mujoco.MjData, command: ServoCommand) -> None:
    # Position actuator: force = gain * ctrl + bias0 + bias1 q + bias2 qd.
    model.actuator_gainprm[:, 0] = command.kp
    model.actuator_biasprm[:, 0] = command.kd * command.qd_ref
    model.actuator_biasprm[:, 1] = -command.kp
    model.actuator_biasprm[:, 2] = -command.kd
    data.ctrl[:] = command.q_ref


def pd_demand(
    command_kp: np.ndarray,
    command_kd: np.ndarray,
    q_ref: np.ndarray,
    qd_ref: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
) -> np.ndarray:
    """The unclamped PD torque K e + B e_dot (Nm); works on (time, joint) arrays."""
    return command_kp * (q_ref - q) + command_kd * (qd_ref - qd)
