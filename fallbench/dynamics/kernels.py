"""Compiled inner steps of the whole-body QP layer (Numba), shared by both QPs.

At 24-82 variables each NumPy call costs more in dispatch (2-5 us) than in arithmetic, and a QP
build was some 60 of them; these kernels do the same arithmetic in one call each. `compiled`
defers Numba to the first call: importing it takes ~0.3 s and its code generator ~0.3 s more, which
only runs that solve a QP need. Kernels are cached next to their source files (`cache=True`), so a
later process loads rather than compiles them. A kernel calls no other kernel (the deferred ones are
plain Python functions until their first call). Kernels copy arrays into slices with element
loops, never `a[:, :k] = b`: Numba's code for a slice assignment cost ~5 s of compilation per
process (every sweep worker of a fresh clone compiles; the kernels took 16 CPU-s, now 10).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

Function = TypeVar("Function", bound=Callable[..., Any])


def compiled(function: Function) -> Function:
    """`function` compiled by Numba (nopython, cached on disk) at its first call."""
    kernel: Callable[..., Any] | None = None

    @functools.wraps(function)
    def call(*args: Any) -> Any:
        nonlocal kernel
        if kernel is None:
            from numba import njit

            kernel = njit(cache=True)(function)
        return kernel(*args)

    return call  # type: ignore[return-value]


@compiled
def symmetric(upper: np.ndarray) -> np.ndarray:
    """The full symmetric matrix from an upper triangle (Pinocchio's crba and computeMinverse fill only that)."""
    full = upper.copy()
    for i in range(len(full)):
        for j in range(i):
            full[i, j] = full[j, i]
    return full


@compiled
def points_kinematics(
    J6: np.ndarray, omega: np.ndarray, acceleration: np.ndarray, body_of: np.ndarray, offsets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (m, 3, nv) and drifts J_dot q_dot (m, 3) of m points fixed in bodies, from each body's
    world-aligned frame Jacobian J6 (bodies, 6, nv), angular velocity omega (bodies, 3) and classical
    acceleration at q_ddot = 0 (bodies, 6); point i is on body body_of[i] at world offset offsets[i] (m)
    from its origin: v_p = v + omega x r, a_p = a + alpha x r + omega x (omega x r)."""
    count, nv = len(body_of), J6.shape[2]
    jacobians, drifts = np.empty((count, 3, nv)), np.empty((count, 3))
    for i in range(count):
        b = body_of[i]
        x, y, z = offsets[i, 0], offsets[i, 1], offsets[i, 2]
        for j in range(nv):  # omega x r = -r x omega, row by row
            wx, wy, wz = J6[b, 3, j], J6[b, 4, j], J6[b, 5, j]
            jacobians[i, 0, j] = J6[b, 0, j] + wy * z - wz * y
            jacobians[i, 1, j] = J6[b, 1, j] + wz * x - wx * z
            jacobians[i, 2, j] = J6[b, 2, j] + wx * y - wy * x
        ax, ay, az = acceleration[b, 3], acceleration[b, 4], acceleration[b, 5]
        wx, wy, wz = omega[b, 0], omega[b, 1], omega[b, 2]
        cx, cy, cz = wy * z - wz * y, wz * x - wx * z, wx * y - wy * x  # omega x r
        drifts[i, 0] = acceleration[b, 0] + ay * z - az * y + wy * cz - wz * cy
        drifts[i, 1] = acceleration[b, 1] + az * x - ax * z + wz * cx - wx * cz
        drifts[i, 2] = acceleration[b, 2] + ax * y - ay * x + wx * cy - wy * cx
    return jacobians, drifts


@compiled
def normal_motion(
    jacobians: np.ndarray, drifts: np.ndarray, normals: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of m points with Jacobians (m, 3, nv), drifts (m, 3) and unit normals (m, 3): the normal rows
    n'J (m, nv), normal drifts n' J_dot q_dot (m,) and the point velocities J v (3 m,)."""
    count, nv = len(normals), len(v)
    rows, normal_drifts, velocities = np.zeros((count, nv)), np.zeros(count), np.zeros(3 * count)
    for i in range(count):
        for d in range(3):
            normal_drifts[i] += normals[i, d] * drifts[i, d]
            for j in range(nv):
                rows[i, j] += normals[i, d] * jacobians[i, d, j]
                velocities[3 * i + d] += jacobians[i, d, j] * v[j]
    return rows, normal_drifts, velocities


@compiled
def force_map(jacobian: np.ndarray, generators: np.ndarray) -> np.ndarray:
    """J'G (nv, 4 n): generalized forces per friction-cone coefficient, from the point Jacobians
    (3 n, nv) and each point's cone generators (n, 3, 4) (G is their block diagonal)."""
    nv, count = jacobian.shape[1], len(generators)
    result = np.zeros((nv, 4 * count))
    for i in range(count):
        for k in range(4):
            for d in range(3):
                edge = generators[i, d, k]
                for j in range(nv):
                    result[j, 4 * i + k] += jacobian[3 * i + d, j] * edge
    return result


@compiled
def independent_rows(
    jacobian: np.ndarray, drift: np.ndarray, body_of: np.ndarray, tolerance: float
) -> np.ndarray:
    """Rows spanning the same constraints as the rows (jacobian | drift) (k, nv + 1), independent within each body.

    Row i is (n'J | n' J_dot q_dot) of a contact point on body body_of[i]. A body's rows are combined
    by the eigenvectors of the Gram matrix of their Jacobian parts (its left singular vectors); a
    combination whose eigenvalue is below tolerance^2 times the body's largest is dropped (four
    corners of a flat foot give three)."""
    count, nv = jacobian.shape
    combined = np.empty((count, nv + 1))
    kept = 0
    for body in range(body_of.max() + 1 if count else 0):
        members = np.nonzero(body_of == body)[0]
        block = np.empty((len(members), nv + 1))  # the body's rows (jacobian | drift)
        for i in range(len(members)):
            for j in range(nv):
                block[i, j] = jacobian[members[i], j]
            block[i, nv] = drift[members[i]]
        block_jacobian = np.ascontiguousarray(block[:, :nv])
        values, vectors = np.linalg.eigh(block_jacobian @ np.ascontiguousarray(block_jacobian.T))
        for k in range(len(values)):
            if values[k] > tolerance**2 * values[-1]:
                row = np.ascontiguousarray(vectors[:, k]) @ block
                for j in range(nv + 1):
                    combined[kept, j] = row[j]
                kept += 1
    return combined[:kept]


@compiled
def scaled_problem(
    M: np.ndarray,
    m: np.ndarray,
    leading: bool,
    W: np.ndarray,
    r: np.ndarray,
    regularisation: np.ndarray,
    A: np.ndarray,
    C: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    scale: np.ndarray,
    ridge: float,
    equilibrate: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cost q_ddot' W q_ddot + 2 r' q_ddot with q_ddot = M y + m (M = [I 0], m = 0 if `leading`),
    plus regularisation y_j^2, in x with y = scale * x, the rows A y, C y and bounds of y likewise;
    `equilibrate`: scale chosen so that H's diagonal is one (where it is positive); then ridge |x|^2.
    Returns (H, g, A, C, lower, upper, scale) in x (see `QPBuilder.build`)."""
    nv, n = M.shape
    if leading:
        H, g = np.zeros((n, n)), np.zeros(n)
        for i in range(nv):
            g[i] = r[i]
            for j in range(nv):
                H[i, j] = W[i, j]
    else:
        Mt = np.ascontiguousarray(M.T)
        H, g = Mt @ (W @ M), Mt @ (W @ m + r)
    scale = scale.copy()
    for j in range(n):
        H[j, j] += regularisation[j]
        if equilibrate and H[j, j] > 0:
            scale[j] = 1.0 / np.sqrt(H[j, j])
    for i in range(n):
        for j in range(n):
            H[i, j] *= scale[i] * scale[j]
        H[i, i] += ridge
    return H, g * scale, A * scale, C * scale, lower / scale, upper / scale, scale


@compiled
def add_task(
    W: np.ndarray,
    r: np.ndarray,
    jacobian: np.ndarray,
    rows: np.ndarray,
    weight: float,
    drift: np.ndarray,
    error: np.ndarray,
    kp: float,
    kv: float,
    v: np.ndarray,
) -> None:
    """W += weight J'J, r += weight J'(drift + kp error + kv J v), in place; J is `jacobian` (k, nv),
    or, when `rows` is not empty, the selection of those (distinct) velocity entries (J'J diagonal)."""
    if len(rows):
        for k in range(len(rows)):
            W[rows[k], rows[k]] += weight
            r[rows[k]] += weight * (drift[k] + kp * error[k] + kv * v[rows[k]])
        return
    k_rows, nv = jacobian.shape
    offset = drift + kp * error + kv * (jacobian @ v)
    products = np.empty(nv)  # row i of J'J, summed over the task's rows in order
    for i in range(nv):
        products[i:] = 0.0
        for k in range(k_rows):
            for j in range(i, nv):  # contiguous in j: vectorised
                products[j] += jacobian[k, i] * jacobian[k, j]
        for j in range(i, nv):
            W[i, j] += weight * products[j]
            if j != i:
                W[j, i] += weight * products[j]
        total = 0.0
        for k in range(k_rows):
            total += jacobian[k, i] * offset[k]
        r[i] += weight * total
