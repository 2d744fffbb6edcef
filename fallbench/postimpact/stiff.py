"""`stiff`: keep the default high PD gains after impact (002 Sec. VI, method 1).

The default gains are the baseline stiffness of the run's world: the robot's times the scenario's
`policy_params.stiff.gain_scale` (`fallbench.sim.baseline`), which every policy uses before impact;
`gain_scale` is declared here, among `stiff`'s parameters, so that scenarios may set it there.
"""

from __future__ import annotations

import numpy as np

from fallbench.postimpact.base import FixedGainPolicy
from fallbench.sim.baseline import DEFAULT_GAIN_SCALE, GAIN_SCALE_KEY


class StiffPolicy(FixedGainPolicy):
    name = "stiff"
    defaults = {GAIN_SCALE_KEY: DEFAULT_GAIN_SCALE}

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return self.default_kp, self.default_kd  # already scaled by gain_scale (the episode's world)
