"""The posture the reshaping controller aims for between fall detection and impact (000 Sec. IV).

Knees bent (lowers the CoM, 002 Sec. IV-C), elbows at the angle of highest manipulability so
they can comply and are not aligned with the impact (000 Sec. IV-B, Fig. 3a), hands pulled up so
the wrists land first (000 Sec. IV-A). The rest stays at the starting posture.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from fallbench.robots.description import RobotDescription


def elbow_angle_max_manipulability(low: float, high: float) -> float:
    """Elbow angle in [low, high] maximising the 2-link arm's manipulability w = l1 l2 |sin(theta)|."""
    angles = np.linspace(low, high, 721)
    return float(angles[np.argmax(np.abs(np.sin(angles)))])


def wrist_up_angle(model: pin.Model, q: np.ndarray, joint: str, hand_frame: str, bend: float) -> float:
    """The wrist pitch, `bend` (0-1) of the way from 0 to one end of its range, that puts the hand
    highest in posture q."""
    data = model.createData()
    index = model.joints[model.getJointId(joint)].idx_q
    best, best_height = 0.0, -np.inf
    for bound in (model.lowerPositionLimit[index], model.upperPositionLimit[index]):
        trial = q.copy()
        trial[index] = bend * bound
        pin.framesForwardKinematics(model, data, trial)
        height = data.oMf[model.getFrameId(hand_frame)].translation[2]
        if height > best_height:
            best, best_height = float(trial[index]), height
    return best


def fall_posture(
    model: pin.Model,
    robot: RobotDescription,
    start: dict[str, float],
    knee_bend: float | None,
    elbow_fraction: float = 1.0,
    wrist_bend: float = 0.8,
) -> dict[str, float]:
    """Joint name -> target angle (rad) for every joint in `start`. `knee_bend` None keeps the
    legs' starting angles; `elbow_fraction` scales the elbow's angle of highest manipulability;
    `wrist_bend` is the hand-up wrist pitch's fraction of its range (`wrist_up_angle`)."""
    target = dict(start)
    legs = (
        zip(*(robot.leg_pitch_joints[k] for k in ("hip", "knee", "ankle"))) if knee_bend is not None else ()
    )
    for hip, knee, ankle in legs:
        target[knee] = knee_bend
        target[hip] = target[ankle] = -knee_bend / 2  # thigh and shank symmetric: the foot stays flat
    q = pin.neutral(model)
    for arm in robot.arms.values():
        index = model.joints[model.getJointId(arm.elbow_joint)].idx_q
        target[arm.elbow_joint] = elbow_fraction * elbow_angle_max_manipulability(
            model.lowerPositionLimit[index], model.upperPositionLimit[index]
        )
    for name, value in target.items():
        q[model.joints[model.getJointId(name)].idx_q] = value
    for arm in robot.arms.values():
        target[arm.wrist_pitch_joint] = wrist_up_angle(
            model, q, arm.wrist_pitch_joint, arm.hand_frame, wrist_bend
        )
    return target
