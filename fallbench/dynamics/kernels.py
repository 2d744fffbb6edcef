"""Compiled inner steps of the whole-body QP layer (Numba), shared by both QPs.

At 24-82 variables each NumPy call costs more in dispatch (2-5 us) than in arithmetic, and a QP
build was some 60 of them; these kernels do the same arithmetic in one call each. They compile on
first use and are cached next to this file (`cache=True`), so later processes load them.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def independent_rows(rows: np.ndarray, body_of: np.ndarray, tolerance: float) -> np.ndarray:
    """Rows spanning the same constraints as `rows` (k, nv + 1), independent within each body.

    Row i is (n'J | n' J_dot q_dot) of a contact point on body body_of[i]. A body's rows are combined
    by the eigenvectors of the Gram matrix of their Jacobian parts (its left singular vectors); a
    combination whose eigenvalue is below tolerance^2 times the body's largest is dropped (four
    corners of a flat foot give three)."""
    count, width = rows.shape
    nv = width - 1
    combined = np.empty((count, width))
    kept = 0
    for body in range(body_of.max() + 1 if count else 0):
        block = np.ascontiguousarray(rows[np.nonzero(body_of == body)[0]])
        jacobian = np.ascontiguousarray(block[:, :nv])
        values, vectors = np.linalg.eigh(jacobian @ np.ascontiguousarray(jacobian.T))
        for k in range(len(values)):
            if values[k] > tolerance**2 * values[-1]:
                combined[kept] = np.ascontiguousarray(vectors[:, k]) @ block
                kept += 1
    return combined[:kept]


@njit(cache=True)
def scaled_problem(M: np.ndarray, m: np.ndarray, leading: bool, W: np.ndarray, r: np.ndarray, regularisation: np.ndarray,
                   A: np.ndarray, C: np.ndarray, lower: np.ndarray, upper: np.ndarray, scale: np.ndarray, ridge: float,
                   equilibrate: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cost q_ddot' W q_ddot + 2 r' q_ddot with q_ddot = M y + m (M = [I 0], m = 0 if `leading`),
    plus regularisation y_j^2, in x with y = scale * x, the rows A y, C y and bounds of y likewise;
    `equilibrate`: scale chosen so that H's diagonal is one (where it is positive); then ridge |x|^2.
    Returns (H, g, A, C, lower, upper, scale) in x (see `QPBuilder.build`)."""
    nv, n = M.shape
    H, g = np.zeros((n, n)), np.zeros(n)
    if leading:
        H[:nv, :nv], g[:nv] = W, r
    else:
        Mt = np.ascontiguousarray(M.T)
        H[:, :] = Mt @ (W @ M)
        g[:] = Mt @ (W @ m + r)
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
