"""`none`: no pre-impact action; the starting references and default gains are held until impact."""

from __future__ import annotations

import mujoco

from fallbench.preimpact.base import Strategy
from fallbench.sim.servo import ServoCommand


class NoStrategy(Strategy):
    name = "none"

    def start(self, t: float, data: mujoco.MjData) -> None:
        pass

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        return None
