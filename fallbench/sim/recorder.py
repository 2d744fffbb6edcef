"""The record of one fall: physics-rate time series, the servo commands held over them, and the
event times. Strategies compute their outcome metrics from it (`OutcomeMetrics`), so they type
the recording by this module, not by the episode loop that fills it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from fallbench.scenario import Scenario
from fallbench.sim.impacts import FirstContact, ImpactEvent
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World


class OutcomeMetrics(Protocol):
    """What the metrics ask of the pre-impact strategy that ran: its own outcome figures."""

    def metrics(self, recording: Recording) -> dict[str, Any]:
        """Per-episode outcome figures computed after the run from its recording."""


@dataclass
class Recording:
    """Time series of one episode: physics-rate arrays, control-rate gains, and event times."""

    world: World
    scenario: Scenario
    time: np.ndarray  # s, (steps,)
    sensordata: np.ndarray  # (steps, nsensordata), at the start of each physics step
    qpos: np.ndarray  # (steps, nq)
    qvel: np.ndarray  # (steps, nv)
    actuator_force: np.ndarray  # Nm, (steps, nu), after the torque limit
    kp: np.ndarray  # Nm/rad held over each physics step, (steps, nu)
    kd: np.ndarray  # Nms/rad, (steps, nu)
    q_ref: np.ndarray  # rad, (steps, nu)
    qd_ref: np.ndarray  # rad/s, (steps, nu)
    fall_time: float | None
    fall_reason: str
    fall_times: dict[str, float]  # s, when each detector fired (selected or not), up to the first impact
    impact_time: float | None  # s, control step at which the policy switched (the takeover)
    impact_bodies: list[str]
    controller_ms: np.ndarray  # ms per control step spent in the strategy and the policy
    switch_time: np.ndarray  # s per motor at which it switched to the gain policy, NaN = never
    physics_s: float = 0.0  # s of wall time inside mj_step
    pre_impact: str = "none"
    impact_events: list[ImpactEvent] = field(
        default_factory=list
    )  # first contact of each body group, in order
    # each body's first contact after the fall was detected: s, and the point (m, world)
    first_contacts: dict[str, FirstContact] = field(default_factory=dict)
    policy_stats: dict[str, float] = field(default_factory=dict)
    # the columns every run's row has, with their values where the controllers that ran give none:
    # every registered strategy's and policy's `stat_columns` (collected by the registry)
    stat_columns: dict[str, Any] = field(default_factory=dict)
    strategy: OutcomeMetrics | None = None  # the pre-impact strategy, for its own metrics
    policy_failure_times: list[float] = field(default_factory=list)  # s, control steps whose policy QP failed
    steps: int = 0
    status: str = "ok"
    error: str = ""
    time_to_rest: float | None = (
        None  # s: start of the stretch at rest that ended the run; None = not settled
    )
    rest_frame: np.ndarray = field(default_factory=lambda: np.eye(3))  # torso forward/left/up at the end
    # (steps, 4) per control step: t (s), capture-point distance (m), tilt (deg), |acc| (m/s^2)
    # up to `body_contact_time` (s: a body other than the feet first touches; None = never)
    detection_signals: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    body_contact_time: float | None = None
    hand_back_time: float | None = None  # s: the strategy handed back, its fall not going on
    strategy_start_time: float | None = None  # s: the pre-impact strategy started (detection.act_on)

    @property
    def contact_times(self) -> dict[str, float]:
        """s, the first contact of each body after the fall was detected."""
        return {body: contact.t for body, contact in self.first_contacts.items()}


INITIAL_ROWS = 8192  # physics steps the trace starts with: 4.1 s at the default 0.5 ms step
TRACE_ARRAYS = ("sensordata", "qpos", "qvel", "actuator_force")  # the physics-rate arrays, in that order


class Trace:
    """The physics-rate arrays of an episode, filled step by step, and the servo changes. They
    grow as the run goes on (`reserve`): a run ends at rest, long before its cap as a rule. Rows
    are read only once written (up to the episode's step): the arrays start uninitialised, not
    zeroed (zeroing some 8 MB took ~0.6 ms a run)."""

    def __init__(self, n_steps: int, nsensordata: int, nq: int, nv: int, nu: int) -> None:
        self.limit = n_steps  # physics steps at the cap
        rows = min(n_steps, INITIAL_ROWS)
        self.sensordata, self.qpos, self.qvel, self.actuator_force = (
            np.empty((rows, columns)) for columns in (nsensordata, nq, nv, nu)
        )
        self.changes: list[tuple[int, ServoCommand]] = []  # (physics step, command) where the servo changed

    def reserve(self, steps: int) -> None:
        """Room for `steps` physics steps (at most the cap's): the arrays double as needed."""
        rows = len(self.qpos)
        if steps <= rows:
            return
        rows = min(max(steps, 2 * rows), self.limit)
        for name in TRACE_ARRAYS:
            old = getattr(self, name)
            grown = np.empty((rows, old.shape[1]))
            grown[: len(old)] = old
            setattr(self, name, grown)

    def held(self, n_steps: int, nu: int) -> np.ndarray:
        """(4, n_steps, nu) kp, kd, q_ref, qd_ref per physics step from the steps where they changed."""
        gains = np.empty((4, n_steps, nu))
        ends = [k for k, _ in self.changes[1:]] + [n_steps]
        for (start, command), end in zip(self.changes, ends):
            gains[:, start:end] = np.stack([command.kp, command.kd, command.q_ref, command.qd_ref])[
                :, None, :
            ]
        return gains
