"""An example plug-in for fallbench: one pre-impact strategy and one gain policy."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from fallbench.postimpact.base import FixedGainPolicy
from fallbench.preimpact.base import Strategy
from fallbench.sim.servo import ServoCommand


class CrouchStrategy(Strategy):
    """Bend the knees toward `knee_bend` rad at `speed` rad/s from fall detection on."""

    name = "crouch"
    defaults = {"knee_bend": 1.2, "speed": 3.0}

    def start(self, t: float, data: mujoco.MjData) -> None:
        self.q_ref = data.ctrl.copy()  # the references held so far
        self.knees = [self.world.joint_names.index(j) for j in self.world.robot.knee_joints]
        self.start_knees = self.q_ref[self.knees].copy()

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        dt = self.scenario.control_dt
        step = np.clip(
            self.params["knee_bend"] - self.q_ref[self.knees],
            -self.params["speed"] * dt,
            self.params["speed"] * dt,
        )
        self.q_ref = self.q_ref.copy()
        self.q_ref[self.knees] += step
        return ServoCommand(
            self.world.default_kp, self.world.default_kd, self.q_ref, np.zeros_like(self.q_ref)
        )

    def metrics(self, recording: Any) -> dict[str, Any]:
        """How far the knee references moved before impact (rad)."""
        bent = self.q_ref[self.knees] - self.start_knees if hasattr(self, "q_ref") else np.zeros(1)
        return {"crouch_knee_change_rad": float(np.max(bent))}


class SoftPolicy(FixedGainPolicy):
    """At impact, the default gains times `scale`."""

    name = "soft"
    defaults = {"scale": 0.1}

    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        return self.default_kp * self.params["scale"], self.default_kd * self.params["scale"]
