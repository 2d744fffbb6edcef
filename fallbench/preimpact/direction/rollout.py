"""The short-rollout predictor (004 Sec. VI's "better model" for Take a Step;
`policy_params.direction.predictor: rollout`): each candidate is simulated for a short time in a
copy of the robot's present state with the strategy's own swing control and servo (the real swing
timing: the foot lifts, travels, sets down), then the rest of the fall is predicted from the
rolled-out state.

Only what the robot itself would know is used: its own state and model, the ground, and the
objects as the pendulum predictor knows them (circles, for the safe regions and the step targets);
the objects are left out of the rollout (no contact with them is simulated) and so is the push
(an unknown external force). A step's rollout ends `rollout_after_landing` s after its foot is down
(the strategy's own landing test; at the landing itself the body has not yet settled onto the new
support), or after `rollout_horizon` s; Lift a Leg (and No Action, with `rollout_candidates: all`)
runs `rollout_horizon` s. Then (`rollout_remainder`): `pendulum`, 004's inverted pendulum from the
rolled-out CoM state about the rolled-out support (both soles where they are once a step has
landed; a step still in the air is taken to land at its target); or `velocity`, the direction of
the CoM's horizontal velocity then. A rollout whose CoM is already down gives the direction to
where it is.

Real time it is not on this machine: one rollout simulates up to `rollout_horizon` s of the whole
robot (docs/methods/direction.md has the measured planning cost per fall).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.preimpact.direction.candidates import Candidate, FallState, capture_margin, step_directions
from fallbench.preimpact.direction.oracle import run_candidate, step_subset
from fallbench.preimpact.direction.support import sole_corners
from fallbench.sim.events import support_polygon

REMAINDERS = ("pendulum", "velocity")
ROLLED = ("swing", "steps", "all")


def rolled_out(candidate: Candidate, which: str) -> bool:
    """Whether `rollout_candidates` (`which`) has this candidate rolled out (else the pendulum predicts it)."""
    return (
        which == "all" or candidate.kind == "take_step" or (which == "swing" and candidate.kind == "lift_leg")
    )


def rollout_subset(candidates: list[Candidate], config: Any) -> list[Candidate]:
    """The candidates the rollout predicts: No Action, both Lift a Leg, and the steps nearest the
    grid of `rollout_radius_step` m (from `step_radius_min`) x every `rollout_heading_step` deg."""
    radii = np.arange(config.step_radius_min, config.step_radius_max + 1e-9, config.rollout_radius_step)
    return step_subset(candidates, radii, config.rollout_heading_step)


def _support(strategy: Any, copy: mujoco.MjData, candidate: Candidate, landed: bool) -> np.ndarray:
    """The support polygon after the rollout, from the soles where they are: both for No Action and
    a landed step, the stance sole for Lift a Leg, and the stance sole with the swing sole moved
    onto its target for a step still in the air."""
    model, feet = strategy.world.model, strategy.feet
    soles = {side: sole_corners(model, copy, body) for side, body in feet.items()}
    if candidate.kind == "no_action" or (candidate.kind == "take_step" and landed):
        return support_polygon(np.vstack(list(soles.values())))
    swing = candidate.swing
    stance = next(side for side in soles if side != swing)
    if candidate.kind == "lift_leg":
        return soles[stance]
    assert candidate.target is not None
    moved = soles[swing] + (candidate.target - soles[swing].mean(axis=0))
    return support_polygon(np.vstack([soles[stance], moved]))


@dataclass(frozen=True)
class RolledOut:
    """A candidate's prediction from its rollout."""

    direction: float  # rad from the strategy's origin
    capturing: bool  # the fall is predicted to stop on the rolled-out support
    capture_margin: float  # m: the capture point inside the rolled-out support (negative: outside)


def predict_by_rollout(strategy: Any, data: mujoco.MjData, t: float, candidate: Candidate) -> RolledOut:
    """One candidate rolled out from `data` at `t` (s), and the rest of its fall predicted; `data`,
    the strategy and the model are not changed."""
    config = strategy.config
    floor = config.touchdown_fraction * strategy.com_height
    landed: list[float] = []  # s, when the rollout's step landed (the strategy's own landing test)

    def ended(copy: mujoco.MjData, state: RobotState) -> bool:
        if strategy.step_done is not None and not landed:
            landed.append(float(copy.time))
        settled = bool(landed) and copy.time >= landed[0] + config.rollout_after_landing - 1e-9
        return bool(state.com[2] <= floor) or settled

    copy, state, _ = run_candidate(
        strategy,
        data,
        t,
        candidate,
        config.rollout_horizon,
        ended,
        push=False,
        objects=False,
        physics_dt=config.rollout_physics_dt,
    )
    com, velocity = state.com, state.com_velocity
    if com[2] <= floor:
        delta = com[:2] - strategy.origin
        return RolledOut(math.atan2(delta[1], delta[0]) % (2 * math.pi), False, -math.inf)
    polygon = _support(strategy, copy, candidate, bool(landed))
    fall = FallState(com, velocity, 0.0, floor)
    directions, _, inside = step_directions([polygon], com[None], velocity[None], strategy.origin, fall)
    margin = capture_margin(polygon, com, velocity)
    if config.rollout_remainder == "velocity":
        return RolledOut(math.atan2(velocity[1], velocity[0]) % (2 * math.pi), bool(inside[0]), margin)
    return RolledOut(float(directions[0]), bool(inside[0]), margin)
