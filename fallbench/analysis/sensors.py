"""Sensor models: what a robot's IMU and force sensing would read of a simulated fall, at any
physics step.

The simulator samples the accelerometer at every physics step. An impact's spike lasts about a
millisecond, so the raw peak depends on where the steps fall on it: a finer step samples more of
the spike (the landing IMU z peak of `adaptive_qp` on a 1 m TALOS drop read 151, 164 and
181 m/s^2 at 1, 0.5 and 0.25 ms). A real IMU low-passes its accelerometer before sampling it at a
fixed output rate; reading the fall through that model makes the peak a property of the fall.

`ImuModel` defaults to the accelerometer of InvenSense's MPU-6000 family at DLPF_CFG = 1 (register
map, register 26 CONFIG: accelerometer bandwidth 184 Hz, delay 2.0 ms, output rate 1 kHz). The
datasheet gives the bandwidth, not the filter's order: a 2nd-order Butterworth low-pass is the model
(parameters `rate`, `bandwidth`, `order`). The range is not modelled: landings exceed the part's
+-16 g, and a clipped peak would rank nothing.

The filter is exact for the simulated signal: MuJoCo's semi-implicit Euler step holds each
step's acceleration over the step, so the continuous filter discretised with a zero-order hold at
the physics step (scipy.signal.cont2discrete) gives the continuous filter's output at every step
boundary, whatever the step. Output samples are taken on the fixed 1/rate grid (interpolated
linearly if the physics step does not divide the sample period).

Contact forces: a stiff contact's per-step force is an integrator artefact (the same impulse spread
over one 1 ms step or four 0.25 ms steps peaks four times higher on the fine one). The headline
force is the largest mean force over `FORCE_WINDOW` (the impulse of the worst window, divided by
its length), a property of the motion the impulse changes; the per-step peaks stay as `*_raw`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

FORCE_WINDOW = 0.005  # s: the papers' control period; an impact on a hard floor lasts a few ms


@dataclass(frozen=True)
class ImuModel:
    """An accelerometer: low-pass `bandwidth` Hz (-3 dB, Butterworth of `order`), sampled at `rate` Hz."""

    rate: float = 1000.0  # Hz, output data rate
    bandwidth: float = 184.0  # Hz
    order: int = 2

    def filtered(self, acc: np.ndarray, dt: float) -> np.ndarray:
        """The low-passed acceleration at every physics sample (m/s^2, same shape as `acc`), starting
        at rest on the first sample (no start-up transient)."""
        from scipy import signal  # here: importing scipy.signal takes ~0.5 s, and only runs filter

        b, a, zi = _discrete_filter(self.order, self.bandwidth, dt)
        initial = zi[:, None] * acc[:1]
        return signal.lfilter(b, a, acc, axis=0, zi=initial)[0]

    def read(self, time: np.ndarray, acc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(sample times in s, samples in m/s^2): what the IMU outputs over the recording."""
        if len(time) < 2:
            return time, acc
        dt = float(time[1] - time[0])
        # The zero-order-hold filter's output at t_k reflects the inputs held over the steps before.
        smooth = self.filtered(acc, dt)
        grid = np.arange(math.ceil(time[0] * self.rate - 1e-9), math.floor(time[-1] * self.rate + 1e-9) + 1)
        at = grid / self.rate
        columns = [np.interp(at, time, smooth[:, axis]) for axis in range(acc.shape[1])]
        return at, np.stack(columns, axis=1)


@cache
def _discrete_filter(order: int, bandwidth: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Butterworth low-pass of `order` and `bandwidth` (Hz) discretised with a zero-order hold at
    `dt` (s): numerator, denominator and the steady state of unit input (`lfilter_zi`), read-only.
    Designed once per step size (a sweep's runs share a few): each design runs scipy's matrix
    exponential, after which BLAS worker threads spun and, with the other core busy, slowed the
    next run by tens of ms."""
    from scipy import signal

    numerator, denominator = signal.butter(order, 2 * math.pi * bandwidth, analog=True)
    discrete, poles, _ = signal.cont2discrete((numerator, denominator), dt, method="zoh")
    b, a = np.ravel(discrete), np.ravel(poles)
    zi = signal.lfilter_zi(b, a)
    for array in (b, a, zi):
        array.flags.writeable = False
    return b, a, zi


def window_mean_peak(force: np.ndarray, dt: float, window: float = FORCE_WINDOW) -> float:
    """N: the largest mean of `force` over `window` seconds (its impulse over the worst window,
    divided by the window); NaN for an empty signal."""
    if not len(force):
        return float("nan")
    samples = max(round(window / dt), 1)
    if len(force) < samples:
        return float(force.sum() * dt / window)
    impulse = np.convolve(force, np.ones(samples), mode="valid") * dt
    return float(impulse.max() / (samples * dt))
