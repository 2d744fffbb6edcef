"""Sensor models: the modelled IMU and the windowed contact force read the same fall the same way at
every physics step."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from fallbench.analysis.sensors import ImuModel, window_mean_peak


def _pulse(dt: float, height: float = 1000.0) -> tuple[np.ndarray, np.ndarray]:
    """Gravity plus a 1 ms pulse of `height` m/s^2 at 10 ms: the same continuous signal at any step."""
    time = np.arange(0.0, 0.05, dt)
    acc = np.zeros((len(time), 3))
    acc[:, 2] = 9.81
    acc[(time >= 0.010 - 1e-12) & (time < 0.011 - 1e-12), 2] += height
    return time, acc


def test_imu_reads_a_spike_the_same_at_every_step() -> None:
    readings = [ImuModel().read(*_pulse(dt)) for dt in (0.001, 0.0005, 0.00025)]
    for times, samples in readings[1:]:
        np.testing.assert_allclose(times, readings[0][0])
        np.testing.assert_allclose(samples, readings[0][1], rtol=1e-9)
    raw_peak = max(_pulse(dt)[1][:, 2].max() for dt in (0.001, 0.00025))
    assert 300 < readings[0][1][:, 2].max() < raw_peak  # the low-pass spreads the 1 ms spike


def test_imu_output_rate_and_rest() -> None:
    time = np.arange(0.0, 0.1, 0.00025)
    times, samples = ImuModel(rate=500.0).read(time, np.tile([0.0, 0.0, 9.81], (len(time), 1)))
    np.testing.assert_allclose(np.diff(times), 0.002)  # a sample every 2 ms
    np.testing.assert_allclose(samples[:, 2], 9.81)  # at rest from the first sample: no start-up transient


def test_imu_bandwidth_is_its_minus_3_db_point() -> None:
    dt, model = 0.0001, ImuModel()
    time = np.arange(0.0, 0.5, dt)
    sine = np.sin(2 * np.pi * model.bandwidth * time)[:, None] * np.ones(3)
    settled = model.filtered(sine, dt)[len(time) // 2 :, 0]
    assert np.abs(settled).max() == pytest.approx(1 / np.sqrt(2), rel=0.01)
    slow = np.sin(2 * np.pi * 5.0 * time)[:, None] * np.ones(3)
    assert np.abs(model.filtered(slow, dt)[len(time) // 2 :, 0]).max() == pytest.approx(1.0, rel=0.01)


def test_imu_filter_matches_the_continuous_system() -> None:
    # The zero-order-hold step response equals the analog filter's step response at the samples.
    dt, model = 0.001, ImuModel()
    time = np.arange(0.0, 0.02, dt)
    step = np.zeros((len(time), 3))
    step[1:] = 1.0  # 0 at t=0, then 1: held over every following step
    numerator, denominator = signal.butter(2, 2 * np.pi * model.bandwidth, analog=True)
    _, analog = signal.step((numerator, denominator), T=time[1:] - dt)
    np.testing.assert_allclose(model.filtered(step, dt)[1:, 0], analog, atol=1e-9)


def test_window_mean_peak_by_hand() -> None:
    force = np.array([0.0, 1000.0, 0.0, 0.0, 500.0, 500.0, 0.0])
    assert window_mean_peak(force, dt=0.001, window=0.001) == 1000.0
    assert window_mean_peak(force, dt=0.001, window=0.002) == 500.0  # [1000, 0] or [500, 500]
    assert window_mean_peak(force, dt=0.001, window=0.003) == pytest.approx(1000 / 3)
    # The same impulse (1 N s) over one 1 ms step or four 0.25 ms steps: the same windowed peak.
    coarse = np.zeros(20)
    coarse[5] = 1000.0
    fine = np.zeros(80)
    fine[20:24] = 1000.0
    assert window_mean_peak(coarse, 0.001) == pytest.approx(window_mean_peak(fine, 0.00025))
    assert np.isnan(window_mean_peak(np.zeros(0), 0.001))
