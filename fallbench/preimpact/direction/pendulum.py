"""Fall direction of a rigid robot (joints locked, 004 Sec. III-B) from an inverted pendulum:
the CoM as a point mass on a massless rod from the pivot, hinged about the support polygon's
tipping edge (motion in the plane normal to the edge) or spherical about a vertex. Integrated with
RK4, for many candidates at once, until the CoM is down to the touchdown height."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s^2


@dataclass
class Rollout:
    """One pendulum fall per candidate, sampled every `dt`."""

    dt: float  # s
    com: np.ndarray  # m, (n, steps, 3) CoM positions
    velocity: np.ndarray  # m/s, (n, steps, 3)
    touchdown_step: np.ndarray  # (n,) sample index of touchdown (the last sample if none)
    start: np.ndarray  # m, (n, 3) CoM at the start

    @property
    def time(self) -> np.ndarray:
        """s to touchdown, (n,)."""
        return self.touchdown_step * self.dt

    @property
    def end(self) -> np.ndarray:
        """m, (n, 3) CoM at touchdown."""
        return self.com[np.arange(len(self.com)), self.touchdown_step]

    @property
    def direction(self) -> np.ndarray:
        """rad, (n,): theta_f, from the CoM's ground projection at the start to that at touchdown."""
        delta = self.end[:, :2] - self.start[:, :2]
        return np.arctan2(delta[:, 1], delta[:, 0]) % (2 * math.pi)


def _acceleration(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rod-constrained point mass: gravity normal to the rod, minus the centripetal term."""
    length2 = np.einsum("ij,ij->i", p, p)[:, None]
    radial = p * (p @ GRAVITY)[:, None] / length2
    speed2 = np.einsum("ij,ij->i", v, v)[:, None]
    return GRAVITY - radial - p * speed2 / length2


def rollout(
    pivots: np.ndarray,
    edges: np.ndarray,
    com: np.ndarray,
    velocity: np.ndarray,
    floor_z: float,
    touchdown_height: float,
    dt: float = 0.01,
    max_time: float = 2.0,
) -> Rollout:
    """n pendulum falls. pivots (n, 2) m; edges (n, 2) unit edge directions, zero rows for a vertex;
    com, velocity (n, 3) start states (m, m/s); touchdown when the CoM is `touchdown_height` (m)
    above the floor at `floor_z`."""
    n = len(pivots)
    origin = np.column_stack([pivots, np.full(n, floor_z)])
    axis = np.column_stack([edges, np.zeros(n)])
    p = com - origin
    v = velocity.copy()
    hinged = np.linalg.norm(axis, axis=1) > 0.5
    p[hinged] -= (
        axis[hinged] * np.einsum("ij,ij->i", p[hinged], axis[hinged])[:, None]
    )  # pivot at the CoM's foot on the edge
    v[hinged] -= axis[hinged] * np.einsum("ij,ij->i", v[hinged], axis[hinged])[:, None]
    v -= (
        p * (np.einsum("ij,ij->i", v, p) / np.einsum("ij,ij->i", p, p))[:, None]
    )  # a rigid rod: no radial speed
    offset = com - origin - p  # the constant part along the edge
    steps = int(math.ceil(max_time / dt)) + 1
    coms = np.empty((n, steps, 3))
    vels = np.empty((n, steps, 3))
    down = np.full(n, steps - 1)
    for k in range(steps):
        coms[:, k] = origin + offset + p
        vels[:, k] = v
        landed = (coms[:, k, 2] - floor_z <= touchdown_height) & (down == steps - 1)
        down[landed] = k
        if (down < steps - 1).all() or k == steps - 1:
            coms, vels = coms[:, : k + 1], vels[:, : k + 1]
            break
        a1 = _acceleration(p, v)
        a2 = _acceleration(p + 0.5 * dt * v, v + 0.5 * dt * a1)
        a3 = _acceleration(p + 0.5 * dt * (v + 0.5 * dt * a1), v + 0.5 * dt * a2)
        a4 = _acceleration(p + dt * (v + 0.5 * dt * a2), v + dt * a3)
        p = p + dt * v + dt**2 / 6 * (a1 + a2 + a3)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    down = np.minimum(down, coms.shape[1] - 1)
    return Rollout(dt, coms, vels, down, com.copy())
