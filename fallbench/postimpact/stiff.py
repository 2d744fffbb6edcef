"""`stiff`: keep the default high PD gains after impact (002 Sec. VI, method 1).

The paper gives no gain values ("very high"), so the baseline stiffness is a parameter:
`gain_scale` multiplies the robot's default K and B. It sets the default gains of every policy
(before impact for all of them, after impact for `stiff`), so a sweep over it shows how each
policy's comparison with `stiff` depends on how stiff the baseline is.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fallbench.postimpact.base import FixedGainPolicy

if TYPE_CHECKING:
    from fallbench.scenario import Scenario


class StiffPolicy(FixedGainPolicy):
    name = "stiff"
    defaults = {"gain_scale": 1.0}

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return self.default_kp, self.default_kd  # already scaled by gain_scale (the episode's world)


def gain_scale(scenario: Scenario) -> float:
    """`policy_params.stiff.gain_scale` (default 1): factor on the default K and B of every policy."""
    return float(
        scenario.policy_params.get(StiffPolicy.name, {}).get("gain_scale", StiffPolicy.defaults["gain_scale"])
    )
