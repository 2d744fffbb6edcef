"""Fall singularities (000 Def. 1, eq. 1) and the fall posture that avoids them."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.fall_singularity import Impact, singular_joints
from fallbench.dynamics.model import PinocchioModel
from fallbench.preimpact.reshape.fall_posture import elbow_angle_max_manipulability, fall_posture
from fallbench.sim.world import World

ELBOW = "arm_left_4_joint"


def _configuration(robot: PinocchioModel, joints: dict[str, float]) -> np.ndarray:
    q = pin.neutral(robot.model)
    for name, value in joints.items():
        q[robot.model.joints[robot.model.getJointId(name)].idx_q] = value
    return q


def _wrist_impact(robot: PinocchioModel, q: np.ndarray, along_forearm: bool) -> Impact:
    """A force at the wrist pushing back along the forearm (Def. 1), or across it."""
    pin.forwardKinematics(robot.model, robot.data, q)
    elbow = robot.data.oMi[robot.model.getJointId(ELBOW)].translation
    wrist = robot.data.oMi[robot.model.getJointId("arm_left_7_joint")].translation
    forearm = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    joint = robot.model.getJointId(ELBOW)
    pin.computeJointJacobians(robot.model, robot.data, q)
    axis = pin.getJointJacobian(robot.model, robot.data, joint, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[
        3:, robot.model.joints[joint].idx_v
    ]
    across = np.cross(axis, forearm)  # the lever's full torque
    force = -forearm if along_forearm else across / np.linalg.norm(across)
    return Impact("arm_left_7_link", wrist, 500.0 * force)


def test_force_along_the_forearm_leaves_the_elbow_unloaded(robot: PinocchioModel) -> None:
    q = _configuration(robot, {ELBOW: -1.2})
    assert ELBOW in singular_joints(
        robot.model, robot.data, q, [_wrist_impact(robot, q, along_forearm=True)], [ELBOW]
    )
    assert ELBOW not in singular_joints(
        robot.model, robot.data, q, [_wrist_impact(robot, q, along_forearm=False)], [ELBOW]
    )


def test_torque_is_eq1_sum_of_jacobian_transpose_forces(robot: PinocchioModel) -> None:
    """Two impacts whose elbow torques cancel (a closed-loop singularity, eq. 1) are singular together
    although each alone is not."""
    q = _configuration(robot, {ELBOW: -1.2})
    across = _wrist_impact(robot, q, along_forearm=False)
    opposite = Impact(across.body, across.point, -across.force)
    assert singular_joints(robot.model, robot.data, q, [across], [ELBOW]) == []
    assert singular_joints(robot.model, robot.data, q, [across, opposite], [ELBOW]) == [ELBOW]


def test_fall_posture_bends_elbows_knees_and_wrists(world: World, robot: PinocchioModel) -> None:
    start = {j: 0.0 for j in world.joint_names}
    target = fall_posture(robot.model, world.robot, start, knee_bend=1.6)
    assert (
        target["leg_left_4_joint"] == 1.6 and target["leg_left_3_joint"] == target["leg_left_5_joint"] == -0.8
    )
    assert target[ELBOW] == pytest.approx(-np.pi / 2, abs=0.01)  # |sin| is largest at a right angle
    assert elbow_angle_max_manipulability(-0.5, 0.0) == pytest.approx(-0.5)  # the range's end nearest pi/2
    assert abs(target["arm_left_6_joint"]) > 0.5 and abs(target["arm_right_6_joint"]) > 0.5
