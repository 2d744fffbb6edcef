"""What the episode loop asks of its two controllers, as small protocols: the pre-impact strategy
(fall detection to impact) and the post-impact gain policy. The base classes users subclass,
with parameters and defaults, are `fallbench.preimpact.base.Strategy` and
`fallbench.postimpact.base.GainPolicy`; the loop only needs these methods."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np

from fallbench.sim.recorder import Recording
from fallbench.sim.servo import ServoCommand


@dataclass
class Observation:
    """What the controller measures at a control step (base state from the simulator's truth)."""

    t: float  # s
    qpos: np.ndarray  # full configuration, MuJoCo order (free joint first)
    qvel: np.ndarray  # full velocity, MuJoCo order
    q: np.ndarray  # actuated joints, rad
    qd: np.ndarray  # actuated joints, rad/s
    touching: set[str]  # robot bodies in contact with the environment now
    data: mujoco.MjData  # the simulator's data, read-only, for policies that need contact points


class PreImpactController(Protocol):
    """Between fall detection and impact (`Strategy` implements it)."""

    per_chain_switching: bool  # each motor switches when its own chain touches down (002 Sec. V)
    hands_over: bool  # False: a whole-fall controller, whose motors never switch to the gain policy
    start_margin: float | None  # m of the capture point outside the support to start on (`Strategy`)

    def start(self, t: float, data: mujoco.MjData) -> None: ...
    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None: ...
    def planned_contacts(self) -> set[str]: ...
    def stats(self) -> dict[str, Any]: ...
    def metrics(self, recording: Recording) -> dict[str, Any]: ...


class PostImpactController(Protocol):
    """After impact (`GainPolicy` implements it)."""

    static: bool  # the command depends only on q_ref: asked for again only when q_ref changes
    needs_contacts: bool  # `Observation.touching` must be filled

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand: ...
    def stats(self) -> dict[str, float]: ...
    def failure_times(self) -> list[float]: ...
