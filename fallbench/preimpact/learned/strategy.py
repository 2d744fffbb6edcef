"""The whole-fall controller a learned policy drives: from fall detection to the episode's end it
reads the `fallbench-obs-v1` observation at its own control rate (`control_dt`, s; 50 Hz by default,
the rate learned fall policies are trained at) and turns the policy's action into joint targets
held by the robot's learned-policy PD gains. It never hands its motors to a gain policy."""

from __future__ import annotations

from abc import abstractmethod
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from fallbench.preimpact.base import Strategy
from fallbench.preimpact.learned.observation import OBSERVATION_VERSION, JointLayout
from fallbench.sim.servo import ServoCommand

if TYPE_CHECKING:
    from fallbench.scenario import Scenario
    from fallbench.sim.world import World

GRID_TOLERANCE = 1e-9  # s

LEARNED_DEFAULTS: dict[str, Any] = {
    "control_dt": 0.02,  # s between the policy's decisions (50 Hz); a multiple of the scenario's control_dt
    "action_scale": 0.5,  # rad per unit of action: q_ref = q_default + action_scale * clip(a, -1, 1)
    "observation": OBSERVATION_VERSION,  # the observation and action layout the policy was trained with
}


class LearnedStrategy(Strategy):
    """A whole-fall controller acting on `fallbench-obs-v1` (subclasses decide the action)."""

    hands_over = False
    defaults = LEARNED_DEFAULTS
    robot_needs = ("learned_gain_groups",)  # the servo the policy was trained with
    choices = {"observation": (OBSERVATION_VERSION,)}

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.layout = JointLayout.of(world)
        self.last_action = np.zeros(self.layout.joints)
        self.started_at = 0.0  # s, fall detection
        self.decisions = 0

    @classmethod
    def check(cls, scenario: Scenario) -> tuple[str, str] | None:
        params = {**cls.defaults, **scenario.policy_params.get(cls.name, {})}
        period, key = params["control_dt"], f"policy_params.{cls.name}"
        ratio = period / scenario.control_dt
        if period <= 0 or ratio < 1 - GRID_TOLERANCE or abs(ratio - round(ratio)) > 1e-6:
            return (
                f"{key}.control_dt",
                f"must be a positive multiple of the scenario's control_dt ({scenario.control_dt} s), got {period} s",
            )
        if params["action_scale"] <= 0:
            return f"{key}.action_scale", f"must be > 0 rad (got {params['action_scale']})"
        return None

    def start(self, t: float, data: mujoco.MjData) -> None:
        self.started_at, self.decisions = t, 0
        self.last_action = np.zeros(self.layout.joints)

    def due(self, t: float) -> bool:
        """Whether the policy decides at t (s): its own grid from fall detection on."""
        return t >= self.started_at + self.decisions * self.params["control_dt"] - GRID_TOLERANCE

    def observe(self, data: mujoco.MjData) -> np.ndarray:
        return self.layout.observe(data, self.last_action)

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        if not self.due(t):
            return None  # between decisions the servo holds the last targets
        action = np.clip(np.asarray(self.decide(self.observe(data)), dtype=float), -1.0, 1.0)
        self.decisions += 1
        self.last_action = action
        return self.layout.command(action, self.params["action_scale"])

    @abstractmethod
    def decide(self, observation: np.ndarray) -> np.ndarray:
        """The action (one value per actuated joint) for a `fallbench-obs-v1` observation."""

    def stats(self) -> dict[str, Any]:
        return {"policy_decisions": self.decisions}
