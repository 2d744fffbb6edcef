"""`stiff`: keep the default high PD gains after impact (002 Sec. VI, method 1)."""

from __future__ import annotations

import numpy as np

from fallbench.policies.base import FixedGainPolicy


class StiffPolicy(FixedGainPolicy):
    name = "stiff"

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return self.default_kp, self.default_kd
