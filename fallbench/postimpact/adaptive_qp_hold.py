"""`adaptive_qp_hold`: `adaptive_qp` (002 Sec. V) through the landing, then the baseline's hold.

An extension of ours, not 002's: 002's QP absorbs the impact but says nothing about what follows
it; with the gain regularisation (eq. 14) it drives the damping toward zero a few hundred ms after
the impact, and the landed robot collapses. This policy runs `adaptive_qp` unchanged (an inner
`AdaptiveQPPolicy` with the same QP parameters) until the impact counts as absorbed, then solves
no further QP and blends every motor's K and B linearly, over `blend_time`, from the QP's last
gains to the baseline `stiff` gains (the robot's default gains), so that no gain step causes a
torque spike. The stiff gains pull toward the landing crouch (`hold_pose: landing`, the joint
angles at the absorption; the reference moves with the blend so that the PD torque is the blend
of the QP's PD toward the impact pose and the stiff PD toward the crouch) or toward the impact
pose (`hold_pose: impact`, `stiff`'s reference). After the blend the command is constant.

Only a landing goes to the QP (`qp_impacts: feet`): a first impact on any body but the feet (a
knee or a hand of a robot tipping over) counts as absorbed at the takeover, so the hold starts at
once; on G1's pushes the QP's 50 ms of soft legs there raised the torso peak (measured in the docs).
The impact counts as absorbed at the first control step after the takeover at which the base's
vertical velocity (m/s, the simulator's root velocity, as `adaptive_qp` reads its base state) is
above -`hold_speed` (the descent has nearly stopped), or at the latest `hold_after` seconds after
the takeover. Defaults chosen on development falls (docs/methods/adaptive_qp.md, "After the
landing: adaptive_qp_hold").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from fallbench.postimpact.adaptive_qp.policy import AdaptiveQPPolicy
from fallbench.postimpact.base import GainPolicy
from fallbench.scenario import Scenario
from fallbench.sim.controllers import Observation
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World

TIME_TOLERANCE = 1e-9  # s: control-step times are sums of floats


@dataclass(frozen=True)
class HoldConfig:
    """When the landing counts as absorbed, and how fast the gains go to the baseline's."""

    hold_speed: float = 1.0  # m/s: absorbed once the base's downward speed is below this
    hold_after: float = 0.2  # s after the takeover: absorbed at the latest then
    blend_time: float = 0.05  # s: linear blend from the QP's gains to the stiff gains
    # the stiff gains' reference: "landing" (the joint angles at the absorption) or "impact" (q_ref)
    hold_pose: str = "landing"
    # the first impacts the QP absorbs: "feet" (a landing; an impact on any other body, e.g. a knee
    # or hand of a robot tipping over, is held at once) or "any" (the QP takes every impact)
    qp_impacts: str = "feet"


HOLD_DEFAULTS: dict[str, Any] = {name: getattr(HoldConfig, name) for name in HoldConfig.__annotations__}
HOLD_POSES = ("landing", "impact")
QP_IMPACTS = ("feet", "any")


@dataclass(frozen=True)
class Absorption:
    """The step at which the impact counted as absorbed and the QP's gains then."""

    t: float  # s
    kp: np.ndarray  # Nm/rad
    kd: np.ndarray  # Nms/rad
    q: np.ndarray  # rad: the landing pose, the actuated joints then


def blend_weight(elapsed: float, blend_time: float) -> float:
    """The stiff gains' share (0..1) `elapsed` s after the absorption, linear over `blend_time` s."""
    if elapsed >= blend_time - TIME_TOLERANCE:  # also a zero blend_time: a step
        return 1.0
    return float(max(elapsed / blend_time, 0.0))


def absorbed(since_takeover: float, vertical_velocity: float, config: HoldConfig) -> bool:
    """Whether the impact counts as absorbed: the base's vertical velocity (m/s, up positive) above
    -hold_speed, or `since_takeover` (s) at least hold_after."""
    return vertical_velocity > -config.hold_speed or since_takeover >= config.hold_after


def blended_reference(
    share: float, kp_from: np.ndarray, q_from: np.ndarray, kp_to: np.ndarray, q_to: np.ndarray
) -> np.ndarray:
    """The one reference q (rad) with which K = (1 - s) K_from + s K_to pulls as the blend of both
    PDs: K (q - q_j) = (1 - s) K_from (q_from - q_j) + s K_to (q_to - q_j) at any joint angle q_j,
    so the torque moves continuously with the share s; q_from where K is zero, q_to at s = 1."""
    if share >= 1.0:
        return q_to.copy()
    kp = (1.0 - share) * kp_from + share * kp_to
    pulled = (1.0 - share) * kp_from * q_from + share * kp_to * q_to
    return np.where(kp > 0, pulled / np.where(kp > 0, kp, 1.0), q_from)


class AdaptiveQPHoldPolicy(GainPolicy):
    name = "adaptive_qp_hold"
    needs_contacts = True
    defaults: dict[str, Any] = AdaptiveQPPolicy.defaults | HOLD_DEFAULTS
    choices = AdaptiveQPPolicy.choices | {"hold_pose": HOLD_POSES, "qp_impacts": QP_IMPACTS}
    stat_columns = AdaptiveQPPolicy.stat_columns  # its stats are adaptive_qp's and `hold_start`

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.config = HoldConfig(**{key: self.params[key] for key in HOLD_DEFAULTS})
        qp_params = {key: self.params[key] for key in AdaptiveQPPolicy.defaults}
        policy_params = scenario.policy_params | {AdaptiveQPPolicy.name: qp_params}
        self.qp = AdaptiveQPPolicy(world, scenario.model_copy(update={"policy_params": policy_params}))
        self.takeover: float | None = None  # s: the first post-impact step
        self.absorption: Absorption | None = None
        self.feet = set(world.robot.body_groups.get("feet", ()))
        self.landing = True  # whether the first impact is on the feet only (set at the takeover)

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        if self.takeover is None:
            self.takeover = observation.t
            self.landing = self.config.qp_impacts == "any" or observation.touching <= self.feet
        if self.absorption is None:
            elapsed = observation.t - self.takeover
            if self.landing and not absorbed(elapsed, float(observation.qvel[2]), self.config):
                return self.qp.after_impact(observation, q_ref)
            self.absorption = Absorption(
                observation.t, self.qp.kp.copy(), self.qp.kd.copy(), observation.q.copy()
            )
        return self.hold_command(observation.t, q_ref)

    def hold_command(self, t: float, q_ref: np.ndarray) -> ServoCommand:
        """The gains at `t` (s) after the absorption: the QP's last ones blended into the defaults."""
        assert self.absorption is not None
        share = blend_weight(t - self.absorption.t, self.config.blend_time)
        kp = (1.0 - share) * self.absorption.kp + share * self.default_kp
        kd = (1.0 - share) * self.absorption.kd + share * self.default_kd
        target = q_ref
        if self.config.hold_pose == "landing":
            target = blended_reference(share, self.absorption.kp, q_ref, self.default_kp, self.absorption.q)
        return ServoCommand(kp, kd, target, np.zeros_like(q_ref))

    def stats(self) -> dict[str, float]:
        """`adaptive_qp`'s figures and `hold_start` (s after the takeover; NaN if never absorbed)."""
        start = float("nan")
        if self.absorption is not None and self.takeover is not None:
            start = self.absorption.t - self.takeover
        return self.qp.stats() | {"hold_start": start}

    def failure_times(self) -> list[float]:
        return self.qp.failure_times()
