"""`oneshot`: at impact, P gain / 1000 and D gain / 100, then held (000, Humanoids 2015 Sec. VI)."""

from __future__ import annotations

import numpy as np

from fallbench.postimpact.base import FixedGainPolicy


class OneshotPolicy(FixedGainPolicy):
    name = "oneshot"
    defaults = {"kp_factor": 1e-3, "kd_factor": 1e-2}

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return self.default_kp * float(self.params["kp_factor"]), self.default_kd * float(
            self.params["kd_factor"]
        )
