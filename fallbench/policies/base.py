"""The small interface every post-impact gain policy implements."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fallbench.servo import ServoCommand

if TYPE_CHECKING:
    from fallbench.world import World


@dataclass
class Observation:
    """What the controller measures at a control step (base state from the simulator's truth)."""

    t: float  # s
    qpos: np.ndarray  # full configuration, MuJoCo order (free joint first)
    qvel: np.ndarray  # full velocity, MuJoCo order
    q: np.ndarray  # actuated joints, rad
    qd: np.ndarray  # actuated joints, rad/s
    touching: set[str]  # robot bodies in contact with the environment now
    contacts: list[Any] = field(default_factory=list)  # simulator contact points, for QP policies


class GainPolicy(ABC):
    """Decides K, B, q_ref, qd_ref after impact. Before impact every policy uses the defaults."""

    name: str = ""

    defaults: dict[str, Any] = {}

    def __init__(self, world: "World", params: dict[str, Any]) -> None:
        unknown = set(params) - set(self.defaults)
        if unknown:
            raise ValueError(f"policy {self.name!r}: unknown parameter(s) {', '.join(sorted(unknown))}; "
                             f"known: {', '.join(sorted(self.defaults)) or 'none'}")
        self.world = world
        self.default_kp = world.default_kp
        self.default_kd = world.default_kd
        self.params = {**self.defaults, **params}

    @abstractmethod
    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        """The servo command for one control step after impact; q_ref = pose just before impact."""

    def stats(self) -> dict[str, float]:
        """Per-episode controller figures (QP timings, failures) stored with the metrics."""
        return {}

    def step_record(self) -> dict[str, float]:
        """Per-control-step figures (status, iterations, solve time) for the time series."""
        return {}


def hold(q_ref: np.ndarray) -> np.ndarray:
    return np.zeros_like(q_ref)
