"""Metrics on hand-computable signals."""

from __future__ import annotations

import numpy as np

from fallbench.metrics import imu_metrics, joint_limit_margins, moving_average, torque_metrics


def test_imu_peaks_raw_and_smoothed() -> None:
    acc = np.zeros((100, 3))
    acc[:, 2] = 9.81
    acc[50, 2] = 109.81  # one-sample spike of +100 m/s^2 at 1 kHz
    acc[50, 0] = -30.0
    m = imu_metrics(acc, dt=0.001)
    assert m["imu_peak_z"] == 109.81
    assert np.isclose(m["imu_peak_norm"], np.hypot(109.81, 30.0))
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
