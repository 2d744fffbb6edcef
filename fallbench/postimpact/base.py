"""The small interface every post-impact gain policy implements."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np

from fallbench.scenario import resolved_params
from fallbench.sim.controllers import Observation
from fallbench.sim.servo import ServoCommand

if TYPE_CHECKING:
    from fallbench.scenario import Scenario
    from fallbench.sim.world import World


class GainPolicy(ABC):
    """Decides K, B, q_ref, qd_ref after impact. Before impact every policy uses the defaults."""

    name: str = ""
    needs_contacts: bool = False  # whether `Observation.touching` must be filled after impact
    static: bool = (
        False  # True: the command depends only on q_ref, so it is asked for again only when q_ref changes
    )

    defaults: dict[str, Any] = {}
    choices: dict[
        str, tuple[str, ...]
    ] = {}  # the allowed values of text parameters, checked when scenarios load
    # Columns of its `stats` that every run's row carries, whichever policy ran, with the value of
    # the runs it did not take part in (the registry collects them; other columns of its own appear
    # only in its runs' rows).
    stat_columns: dict[str, Any] = {}

    def __init__(self, world: World, scenario: Scenario) -> None:
        self.params = resolved_params(
            "policy", self.name, self.defaults, scenario.policy_params.get(self.name, {})
        )
        self.world = world
        self.scenario = scenario
        self.default_kp = world.default_kp
        self.default_kd = world.default_kd

    @abstractmethod
    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        """The servo command for one control step after impact; q_ref = pose just before impact."""

    def stats(self) -> dict[str, float]:
        """Per-episode controller figures (QP timings, failures) stored with the metrics."""
        return {}

    def failure_times(self) -> list[float]:
        """Control steps (s) at which the policy failed to decide (a QP that did not solve)."""
        return []


class FixedGainPolicy(GainPolicy):
    """A policy that sets constant gains at impact and holds q_ref."""

    static = True
    command: ServoCommand | None = None

    @abstractmethod
    def impact_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """K (Nm/rad) and B (Nms/rad) per actuated joint from the impact on."""

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        # rebuilt only when q_ref changes (a chain switching later): the servo is rewritten only then
        if self.command is None or self.command.q_ref is not q_ref:
            kp, kd = self.impact_gains()
            self.command = ServoCommand(kp, kd, q_ref, np.zeros_like(q_ref))
        return self.command
