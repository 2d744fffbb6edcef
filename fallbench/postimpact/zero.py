"""`zero`: servo off at impact, K = B = 0 (002 Sec. VI, method 3)."""

from __future__ import annotations

import numpy as np

from fallbench.postimpact.base import FixedGainPolicy


class ZeroPolicy(FixedGainPolicy):
    name = "zero"

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros_like(self.default_kp), np.zeros_like(self.default_kd)
