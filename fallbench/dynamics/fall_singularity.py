"""Fall singularities (000 Sec. III): joints an impact cannot load, so they cannot comply.

Def. 1 (the line through an impacting body's joint and its parent's is aligned with the impact
force) and the closed-loop case of eq. 1 ((sum_i J_i' f_i) . S_M = 0) are one test: the torque
the impact forces produce on a motor is (close to) zero. It is compared with the largest torque
those forces could produce at that joint, sum_i |f_i| |r_ij| (r_ij from the joint to point i),
so the test reads as the sine of the angle between force and lever arm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from fallbench.dynamics.vectors import cross

SINGULAR_SINE = float(np.sin(np.radians(10.0)))  # force within 10 deg of the lever arm: singular
MIN_LEVER = 0.05  # m: joints closer than this to every impact point are not judged


@dataclass
class Impact:
    body: str  # Pinocchio frame of the impacting body
    point: np.ndarray  # m, world
    force: np.ndarray  # N (or any positive multiple), world, applied on the robot


def singular_joints(
    model: pin.Model, data: pin.Data, q: np.ndarray, impacts: list[Impact], joints: list[str]
) -> list[str]:
    """Names among `joints` (revolute, on the impacting chains) that the impacts leave unloaded."""
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    pin.computeJointJacobians(model, data, q)
    torque = np.zeros(model.nv)
    for impact in impacts:
        # the force at the point as a wrench at the body frame's origin (world-aligned): (f, r x f)
        frame = model.getFrameId(impact.body)
        lever = impact.point - data.oMf[frame].translation
        J6 = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        torque += J6.T @ np.concatenate([impact.force, cross(lever, impact.force)])
    singular = []
    for name in joints:
        joint = model.getJointId(name)
        origin = data.oMi[joint].translation
        on_chain = [
            i for i in impacts if joint in model.supports[model.frames[model.getFrameId(i.body)].parentJoint]
        ]
        levers = [float(np.linalg.norm(i.point - origin)) for i in on_chain]
        reach = sum(float(np.linalg.norm(i.force)) * lever for i, lever in zip(on_chain, levers))
        if (
            levers
            and max(levers) >= MIN_LEVER
            and abs(torque[model.joints[joint].idx_v]) < SINGULAR_SINE * reach
        ):
            singular.append(name)
    return singular
