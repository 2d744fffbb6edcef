"""Metrics on hand-computable signals."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.analysis.metrics import (
    imu_metrics,
    joint_limit_margins,
    landing_metrics,
    moving_average,
    torque_metrics,
)
from fallbench.sim.world import found_columns


def test_imu_peaks_raw_and_smoothed() -> None:
    acc = np.zeros((100, 3))
    acc[:, 2] = 9.81
    acc[50, 2] = 109.81  # one-sample spike of +100 m/s^2 at 1 kHz
    acc[50, 0] = -30.0
    m = imu_metrics(acc, dt=0.001)
    assert m["imu_peak_z_raw"] == 109.81
    assert np.isclose(m["imu_peak_norm_raw"], np.hypot(109.81, 30.0))
    # a 5-sample moving average spreads the spike: 9.81 + 100 / 5
    assert np.isclose(m["imu_peak_z_5ms"], 29.81)


def test_moving_average_of_a_ramp() -> None:
    np.testing.assert_allclose(moving_average(np.arange(6.0), 3), [1.0, 2.0, 3.0, 4.0])


def test_joint_limit_margins_sign() -> None:
    limits = np.array([[0.0, 2.618], [-1.0, 1.0]])
    q = np.array([[0.5, 0.9], [2.7, -1.2]])
    margins = joint_limit_margins(q, limits)
    np.testing.assert_allclose(margins, [[0.5, 0.1], [2.618 - 2.7, -0.2]])


def test_torque_ratios_and_saturation_time() -> None:
    limit = np.array([100.0, 10.0])
    demand = np.array([[50.0, 5.0], [150.0, 5.0], [0.0, -20.0], [0.0, 0.0]])
    applied = np.clip(demand, -limit, limit)
    m = torque_metrics(applied, demand, limit, dt=0.001)
    assert m["torque_ratio_max"] == 1.0
    assert m["torque_demand_ratio_max"] == 2.0
    assert np.isclose(m["saturation_time"], 0.002)  # two samples with a joint past its limit


def test_damage_measures_on_hand_made_signals() -> None:
    """Body-weight forces, per-chain torque peaks and vulnerable parts hit, computed by hand."""
    from types import SimpleNamespace

    from fallbench.analysis.metrics import damage_metrics

    robot = SimpleNamespace(
        torque_chains={"legs": r"leg_.*", "arms": r"arm_.*"},
        vulnerable_parts={"head": ("head_link",), "gripper_left": ("gripper_a", "gripper_b")},
    )
    model = SimpleNamespace(body_subtreemass=np.array([0.0, 10.0]))
    world = SimpleNamespace(
        model=model,
        root_body=1,
        robot=robot,
        joint_names=("leg_1", "leg_2", "arm_1"),
        contact_bodies=["head_link", "gripper_a", "gripper_b", "foot"],
        contact_found_columns=np.array([0, 1, 2, 3]),
        contact_found_index=found_columns(np.array([0, 1, 2, 3])),
    )
    sensordata = np.zeros((4, 4))
    sensordata[2, 1] = sensordata[3, 2] = 1  # both bodies of the left gripper touch: one part
    sensordata[:, 3] = 1  # the foot is not vulnerable
    torques = np.array([[10.0, -150.0, 3.0], [20.0, 40.0, -30.0], [0, 0, 0], [0, 0, 0]])
    rec = SimpleNamespace(world=world, actuator_force=torques, sensordata=sensordata, steps=4)
    forces = {
        "total": np.array([0.0, 981.0, 196.2, 0.0]),
        "head": np.zeros(4),
        "torso": np.array([0.0, 98.1, 0, 0]),
    }
    row = damage_metrics(rec, forces, dt=0.001, force_window=0.001)  # one-sample window: the peaks
    assert row["contact_force_peak_bw"] == pytest.approx(10.0)  # 981 N on a 10 kg robot
    assert row["contact_force_peak_head_bw"] == 0.0 and row["contact_force_peak_torso_bw"] == pytest.approx(
        1.0
    )
    # Over 2 ms the worst window holds 981 + 196.2 N for 1 ms each: 588.6 N = 6 body weights.
    assert damage_metrics(rec, forces, dt=0.001, force_window=0.002)[
        "contact_force_peak_bw"
    ] == pytest.approx(6.0)
    assert row["torque_peak_legs"] == 150.0 and row["torque_peak_arms"] == 30.0
    assert row["vulnerable_hits"] == 1
    sensordata[1, 0] = 1  # and the head
    assert damage_metrics(rec, forces, dt=0.001)["vulnerable_hits"] == 2


def test_landing_window_metrics_see_only_the_landing() -> None:
    """Peaks inside [impact, impact + 0.15 s] count; a bigger one 0.2 s later (the fall) does not."""
    time = np.arange(1000) * 0.001
    acc = np.zeros((1000, 3))
    acc[:, 2] = 9.81
    acc[100, 2] = 500.0  # before the impact
    acc[450, 2] = -80.0  # inside, negative
    acc[450, 0] = 60.0
    acc[600, 2] = 70.0  # the window's last sample, inside
    acc[601, 2] = 300.0  # just outside
    limit = np.array([100.0, 10.0])
    demand = np.zeros((1000, 2))
    demand[500, 0] = 250.0  # joint 0 under the policy from 0.45 s: ratio 2.5
    demand[460, 1] = 80.0  # joint 1 switches only at 0.47 s: not counted ...
    demand[480, 1] = 30.0  # ... this one is: ratio 3
    demand[700, 0] = 1e4  # outside the window
    row = landing_metrics(
        time,
        acc,
        demand,
        limit,
        switch_time=np.array([0.451, 0.47]),
        failure_times=[0.3, 0.455, 0.6, 0.605],
        impact=0.45,
        takeover=0.451,
    )
    assert row["imu_peak_z_landing_raw"] == 80.0
    assert np.isclose(row["imu_peak_norm_landing_raw"], 100.0)  # hypot(60, 80)
    assert row["torque_demand_ratio_landing"] == 3.0
    assert row["qp_failures_landing"] == 2  # 0.455 and 0.6 (the window's end is included)
    assert np.isclose(row["takeover_delay"], 0.001)
    shorter = landing_metrics(time, acc, demand, limit, np.array([0.451, 0.47]), [], 0.45, 0.451, length=0.02)
    assert shorter["torque_demand_ratio_landing"] == 0.0 and shorter["imu_peak_z_landing_raw"] == 80.0


def test_landing_metrics_without_impact_are_empty() -> None:
    time = np.arange(10) * 0.001
    row = landing_metrics(
        time, np.ones((10, 3)), np.ones((10, 2)), np.ones(2), np.full(2, np.nan), [], None, None
    )
    assert np.isnan(row["imu_peak_z_landing_raw"]) and np.isnan(row["torque_demand_ratio_landing"])
    assert row["qp_failures_landing"] == 0 and np.isnan(row["takeover_delay"])
