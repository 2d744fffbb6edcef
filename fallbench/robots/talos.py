"""PAL Robotics TALOS (90 kg, 32 actuated joints) from example-robot-data."""

from __future__ import annotations

from importlib.metadata import distribution, version
from pathlib import Path

from fallbench.robots.description import (
    DEFAULT_POSTURE,
    SIDES,
    Arm,
    GainGroup,
    RobotDescription,
    read_srdf_armature,
    read_srdf_disabled_collisions,
    read_srdf_postures,
)

# Stiff position-control gains, of the order of the HRP-4/TALOS defaults used in 002 Sec. VI
# (legs 2000 Nm/rad, 20 Nms/rad).
TALOS_GAINS = (
    GainGroup(r"leg_.*", 2000.0, 20.0),
    GainGroup(r"torso_.*", 1000.0, 10.0),
    GainGroup(r"arm_(left|right)_[1-4]_joint", 500.0, 5.0),
    GainGroup(r"arm_(left|right)_[5-7]_joint", 100.0, 1.0),
    GainGroup(r"head_.*", 50.0, 0.5),
    GainGroup(r"gripper_.*", 50.0, 0.5),
)

# Servo gains under a learned whole-fall policy (strategy `onnx`): G1's (fallbench/robots/g1.py, of
# the vendor's RL deployments) scaled by the stiffness rule of G1's stiff gains (K proportional to
# mass x leg length, K_TALOS = K_G1 / 0.31), rounded; kd/kp ~0.025 s.
TALOS_LEARNED_GAINS = (
    GainGroup(r"leg_(left|right)_[123]_joint", 320.0, 8.0),  # hip yaw, roll, pitch
    GainGroup(r"leg_(left|right)_4_joint", 480.0, 12.0),  # knee
    GainGroup(r"leg_(left|right)_[56]_joint", 130.0, 3.2),  # ankle pitch, roll
    GainGroup(r"torso_.*", 650.0, 16.0),
    GainGroup(r"arm_(left|right)_[1-4]_joint", 130.0, 3.2),
    GainGroup(r"arm_(left|right)_[5-7]_joint", 65.0, 1.6),
    GainGroup(r"head_.*", 15.0, 0.4),
    GainGroup(r"gripper_.*", 15.0, 0.4),
)

# Bodies by the damage group a contact on them counts for.
TALOS_BODY_GROUPS: dict[str, tuple[str, ...]] = {
    "feet": ("leg_left_6_link", "leg_right_6_link", "leg_left_5_link", "leg_right_5_link"),
    "knees": ("leg_left_4_link", "leg_right_4_link", "leg_left_3_link", "leg_right_3_link"),
    "hands": tuple(
        f"{part}_{side}_{suffix}"
        for side in ("left", "right")
        for part, suffix in (
            ("arm", "5_link"),
            ("arm", "6_link"),
            ("arm", "7_link"),
            ("wrist", "ft_link"),
            ("wrist", "ft_tool_link"),
            ("gripper", "base_link"),
            ("gripper", "motor_double_link"),
            ("gripper", "inner_double_link"),
            ("gripper", "fingertip_1_link"),
            ("gripper", "fingertip_2_link"),
            ("gripper", "motor_single_link"),
            ("gripper", "inner_single_link"),
            ("gripper", "fingertip_3_link"),
        )
    ),
    "arms": tuple(f"arm_{side}_{i}_link" for side in ("left", "right") for i in (1, 2, 3, 4)),
    "torso": (
        "base_link",
        "torso_1_link",
        "torso_2_link",
        "leg_left_1_link",
        "leg_right_1_link",
        "leg_left_2_link",
        "leg_right_2_link",
    ),
    "head": ("head_1_link", "head_2_link", "rgbd_link"),
}


# Joints whose angle and torque every run stores: the right leg's pitch joints (Figs. 4-6 of 002),
# the left knee, and the joints of the reshaped-fall figure.
TALOS_TIMESERIES_JOINTS = (
    "leg_right_3_joint",
    "leg_right_4_joint",
    "leg_right_5_joint",
    "leg_left_4_joint",
    "torso_1_joint",
    "arm_left_1_joint",
    "arm_left_4_joint",
    "arm_left_6_joint",
    "arm_right_4_joint",
)
TALOS_TRAJECTORY_JOINTS = {
    "torso_1_joint": "torso yaw",
    "arm_left_1_joint": "left shoulder pitch",
    "arm_left_4_joint": "left elbow",
    "arm_left_6_joint": "left wrist pitch",
    "leg_right_4_joint": "right knee",
}
# Parts a hit on damages (SafeFall's "vulnerable parts"): the head with its camera, and the grippers.
TALOS_VULNERABLE_PARTS = {"head": TALOS_BODY_GROUPS["head"]} | {
    f"gripper_{side}": tuple(b for b in TALOS_BODY_GROUPS["hands"] if b.startswith(f"gripper_{side}_"))
    for side in ("left", "right")
}
TALOS_TORQUE_CHAINS = {"legs": r"leg_.*", "arms": r"arm_.*", "torso": r"torso_.*", "head": r"head_.*"}


def data_root() -> Path:
    """example-robot-data's robots folder (TALOS and G1 come from it)."""
    dist = distribution("example-robot-data")
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))


def talos() -> RobotDescription:
    root = data_root()
    srdf = root / "talos_data/srdf/talos.srdf"
    postures, heights = read_srdf_postures(srdf)
    postures[DEFAULT_POSTURE], heights[DEFAULT_POSTURE] = postures["half_sitting"], heights["half_sitting"]
    return RobotDescription(
        name="talos",
        urdf_path=root / "talos_data/robots/talos_reduced_box.urdf",
        srdf_path=srdf,
        mesh_root=root,
        package_prefix="example-robot-data/robots/",
        version=f"example-robot-data {version('example-robot-data')}",
        root_body="base_link",
        torso_body="torso_2_link",
        imu_body="base_link",  # waist IMU, z up (the real IMU link is on the torso, z down)
        gain_groups=TALOS_GAINS,
        learned_gain_groups=TALOS_LEARNED_GAINS,
        body_groups=TALOS_BODY_GROUPS,
        armature=read_srdf_armature(srdf),
        postures=postures,
        posture_base_height=heights,
        disabled_collisions=read_srdf_disabled_collisions(srdf),
        arms={
            side: Arm(
                f"arm_{side}_1_joint",
                f"arm_{side}_4_joint",
                f"arm_{side}_7_joint",
                f"arm_{side}_7_link",
                f"arm_{side}_6_joint",
                f"gripper_{side}_base_link",
            )
            for side in ("left", "right")
        },
        legs={side: tuple(f"leg_{side}_{i}_joint" for i in range(1, 7)) for side in SIDES},
        leg_pitch_joints={
            "hip": ("leg_left_3_joint", "leg_right_3_joint"),
            "knee": ("leg_left_4_joint", "leg_right_4_joint"),
            "ankle": ("leg_left_5_joint", "leg_right_5_joint"),
        },
        feet={side: f"leg_{side}_6_link" for side in ("left", "right")},
        timeseries_joints=TALOS_TIMESERIES_JOINTS,
        trajectory_joints=TALOS_TRAJECTORY_JOINTS,
        vulnerable_parts=TALOS_VULNERABLE_PARTS,
        torque_chains=TALOS_TORQUE_CHAINS,
    )
