"""3-vector helpers for the control loops: the world's vertical, and a cross product (NumPy's general
`np.cross` costs ~15 us on one pair of 3-vectors, axis handling; this one ~1 us, with the same
products and differences: the same bits)."""

from __future__ import annotations

import numpy as np

UP = np.array([0.0, 0.0, 1.0])  # world z, against gravity


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
