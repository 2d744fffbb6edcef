"""Unitree G1 (33.3 kg, 29 actuated joints) from example-robot-data (`g1_description`).

Gains. `stiff` must mean for G1 what it means for TALOS: high-gain position control that holds
the robot against its own weight (002 Sec. VI gives no numbers, only "very high"). Stiffness rule:
the same joint deflection per unit of gravity load, i.e. K proportional to m g l (mass times leg
length): with m 33.3 / 90.3 kg and leg length (hip pitch axis to ankle pitch axis) 0.60 / 0.71 m,
K_G1 = 0.31 K_TALOS, rounded: legs 600 Nm/rad (TALOS 2000), waist 300 (1000), shoulders and elbows
150 (500), wrists 30 (100). Damping: kd = 0.03 s x kp, inside the range of the PD ratios published
for G1 (vendor RL deployments: kd/kp 0.02-0.027 s; the open simulation models: 0.064 s). TALOS's
0.01 s is too little for G1: measured under `stiff`, the landing springs G1 off the floor and it
tips over from a 0.5 m drop (kd/kp 0.01 s: stays up from 0.25 m only; 0.03 s: from 0.25-1.0 m;
0.05 s: 0.25-1.0 m with 5-10 % higher IMU peaks). For scale: the vendor's low-level examples use
60-150 Nm/rad on the legs, a compliant servo for a learned policy, not a stiff one.

Posture `default`: the knees-bent stance of the G1 keyframe published with MuJoCo's model
collections (hip pitch -0.312, knee 0.669, ankle pitch -0.363 rad, torso upright, elbows 0.6 rad,
shoulders pitched 0.2 rad and rolled out 0.2 rad), G1's counterpart of TALOS's half-sitting.

Armature: reflected rotor inertias of G1's actuators (rotor inertia x gear ratio^2) as published
in the open G1 simulation models (7520-14: 0.0102, 7520-22: 0.0251, 5020: 0.0036, two 5020s on the
ankles and waist roll/pitch: 0.0072, 4010 wrists: 0.0043 kg m^2). An assumption: no vendor
datasheet ships with the URDF.

Collisions: the URDF's collision meshes (convex hulls in MuJoCo) overlap at the hip, pelvis and
shoulder in the default stance; those pairs are disabled (list below, found by compiling the stance
with every pair on). The feet are the URDF's four 5 mm spheres per sole.

IMU: the accelerometer is the URDF's `imu_in_pelvis` frame (pelvis, z up), as on the robot.
"""

from __future__ import annotations

from importlib.metadata import version

from fallbench.robots.description import DEFAULT_POSTURE, SIDES, Arm, GainGroup, RobotDescription
from fallbench.robots.talos import data_root

G1_GAINS = (
    GainGroup(r".*_(hip|knee|ankle)_.*", 600.0, 18.0),
    GainGroup(r"waist_.*", 300.0, 9.0),
    GainGroup(r".*_(shoulder|elbow)_.*", 150.0, 4.5),
    GainGroup(r".*_wrist_.*", 30.0, 0.9),
)

# Servo gains under a learned whole-fall policy (strategy `onnx`, the Gymnasium environment): of the
# vendor's RL deployments (hips 100 Nm/rad, knees 150, ankles 40, kd/kp ~0.025 s), with the waist,
# arms and wrists (which those 12-joint policies leave out) on the same scale: a compliant servo that
# a policy moves by its targets, not the stiff one of `stiff`.
G1_LEARNED_GAINS = (
    GainGroup(r".*_hip_.*", 100.0, 2.5),
    GainGroup(r".*_knee_.*", 150.0, 4.0),
    GainGroup(r".*_ankle_.*", 40.0, 1.0),
    GainGroup(r"waist_.*", 200.0, 5.0),
    GainGroup(r".*_(shoulder|elbow)_.*", 40.0, 1.0),
    GainGroup(r".*_wrist_.*", 20.0, 0.5),
)

_7520_14, _7520_22, _5020, _4010 = 0.010177520, 0.025101925, 0.003609725, 0.00425
G1_ARMATURE = {
    **{
        f"{side}_{joint}_joint": value
        for side in SIDES
        for joint, value in (
            ("hip_pitch", _7520_14),
            ("hip_roll", _7520_22),
            ("hip_yaw", _7520_14),
            ("knee", _7520_22),
            ("ankle_pitch", 2 * _5020),
            ("ankle_roll", 2 * _5020),
            ("shoulder_pitch", _5020),
            ("shoulder_roll", _5020),
            ("shoulder_yaw", _5020),
            ("elbow", _5020),
            ("wrist_roll", _5020),
            ("wrist_pitch", _4010),
            ("wrist_yaw", _4010),
        )
    },
    "waist_yaw_joint": _7520_14,
    "waist_roll_joint": 2 * _5020,
    "waist_pitch_joint": 2 * _5020,
}

G1_BODY_GROUPS: dict[str, tuple[str, ...]] = {
    "feet": tuple(f"{side}_ankle_{part}_link" for side in SIDES for part in ("roll", "pitch")),
    "knees": tuple(f"{side}_{part}_link" for side in SIDES for part in ("knee", "hip_yaw")),
    "hands": tuple(
        f"{side}_{part}"
        for side in SIDES
        for part in ("wrist_roll_link", "wrist_pitch_link", "wrist_yaw_link", "rubber_hand")
    ),
    "arms": tuple(
        f"{side}_{part}_link"
        for side in SIDES
        for part in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")
    ),
    "torso": ("pelvis", "pelvis_contour_link", "torso_link", "logo_link")
    + tuple(f"{side}_hip_{part}_link" for side in SIDES for part in ("pitch", "roll")),
    "head": ("head_link",),
}

# Parts a hit on damages (SafeFall's "vulnerable parts"): the head (cameras, lidar) and the hands.
G1_VULNERABLE_PARTS = {"head": G1_BODY_GROUPS["head"]} | {
    f"hand_{side}": (f"{side}_wrist_yaw_link", f"{side}_rubber_hand") for side in SIDES
}
G1_TORQUE_CHAINS = {
    "legs": r"(left|right)_(hip|knee|ankle)_.*",
    "arms": r"(left|right)_(shoulder|elbow|wrist)_.*",
    "torso": r"waist_.*",
}

G1_DEFAULT = {
    **{
        f"{side}_{joint}_joint": value
        for side in SIDES
        for joint, value in (
            ("hip_pitch", -0.312),
            ("knee", 0.669),
            ("ankle_pitch", -0.363),
            ("elbow", 0.6),
            ("shoulder_pitch", 0.2),
        )
    },
    "left_shoulder_roll_joint": 0.2,
    "right_shoulder_roll_joint": -0.2,
}
G1_STANDING_HEIGHT = 0.755  # m, pelvis height standing in `default` (checked in tests/test_physics.py)

# Every self-collision is on except parent-child pairs (MuJoCo's rule) and these: the wrist's roll
# and yaw hulls touch at the wrist pitch limits (1.7 mm), an artefact of the convex hulls. No pair
# touches in the default stance; swept one joint at a time over its range, the other pairs that
# touch are limbs meeting the body (arm into torso, knee into knee), real collisions kept on.
G1_DISABLED_COLLISIONS = tuple((f"{side}_wrist_roll_link", f"{side}_wrist_yaw_link") for side in SIDES)

G1_TIMESERIES_JOINTS = (
    "right_hip_pitch_joint",
    "right_knee_joint",
    "right_ankle_pitch_joint",
    "left_knee_joint",
    "waist_yaw_joint",
    "left_shoulder_pitch_joint",
    "left_elbow_joint",
    "left_wrist_pitch_joint",
    "right_elbow_joint",
)
G1_TRAJECTORY_JOINTS = {
    "waist_yaw_joint": "waist yaw",
    "left_shoulder_pitch_joint": "left shoulder pitch",
    "left_elbow_joint": "left elbow",
    "left_wrist_pitch_joint": "left wrist pitch",
    "right_knee_joint": "right knee",
}


def g1() -> RobotDescription:
    root = data_root()
    return RobotDescription(
        name="g1",
        urdf_path=root / "g1_description/urdf/g1_29dof_rev_1_0.urdf",
        mesh_root=root,
        package_prefix="example-robot-data/robots/",
        version=f"example-robot-data {version('example-robot-data')}",
        root_body="pelvis",
        torso_body="torso_link",
        imu_body="imu_in_pelvis",
        gain_groups=G1_GAINS,
        learned_gain_groups=G1_LEARNED_GAINS,
        body_groups=G1_BODY_GROUPS,
        feet={side: f"{side}_ankle_roll_link" for side in SIDES},
        legs={
            side: tuple(
                f"{side}_{j}_joint"
                for j in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
            )
            for side in SIDES
        },
        arms={
            side: Arm(
                f"{side}_shoulder_pitch_joint",
                f"{side}_elbow_joint",
                f"{side}_wrist_yaw_joint",
                f"{side}_wrist_yaw_link",
                f"{side}_wrist_pitch_joint",
                f"{side}_rubber_hand",
            )
            for side in SIDES
        },
        leg_pitch_joints={
            part: tuple(f"{side}_{part}{suffix}_joint" for side in SIDES)  # type: ignore[misc]
            for part, suffix in (("hip", "_pitch"), ("knee", ""), ("ankle", "_pitch"))
        },
        timeseries_joints=G1_TIMESERIES_JOINTS,
        trajectory_joints=G1_TRAJECTORY_JOINTS,
        vulnerable_parts=G1_VULNERABLE_PARTS,
        torque_chains=G1_TORQUE_CHAINS,
        armature=G1_ARMATURE,
        postures={DEFAULT_POSTURE: G1_DEFAULT},
        posture_base_height={DEFAULT_POSTURE: G1_STANDING_HEIGHT},
        disabled_collisions=G1_DISABLED_COLLISIONS,
    )
