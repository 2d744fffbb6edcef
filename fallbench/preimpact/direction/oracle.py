"""The oracle predictor (issue 23 item 4; `policy_params.direction.predictor: oracle`): every
candidate's fall direction is found by simulating that candidate in a copy of the scene, from the
control trigger to the fall's end, instead of by 004's inverted pendulum. A perfect prediction, not
a real-time one (it costs seconds of planning per fall): it bounds what `direction` could reach with
its candidates if prediction were free, separating prediction's cost from the robot's authority.

Each rollout runs the candidate alone (no inertia shaping, no tracking: what the pendulum predicts
too) with the strategy's own swing control and servo, the push as scheduled, and ends at
touchdown (the CoM down to `touchdown_fraction` of its standing height), at the first contact with
an object (then the object sets the direction, as in outcome.py), or `ROLLOUT_LIMIT` s. The
stepping grid is coarser than the pendulum's (`ORACLE_RADII` x every `ORACLE_HEADING` deg) to keep
the rollouts to a few dozen per fall.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.preimpact.direction.candidates import Candidate
from fallbench.preimpact.direction.selection import Plan
from fallbench.sim.events import capture_point
from fallbench.sim.servo import write_servo

ROLLOUT_LIMIT = 2.0  # s after the control trigger
ORACLE_RADII = (0.25, 0.45)  # m, step lengths simulated
ORACLE_HEADING = 45.0  # deg between simulated step headings
SAVED = ("plan", "q_ref", "qd_ref", "step_done", "step_error", "swing_path", "tracked", "tracking_switch")


def oracle_subset(candidates: list[Candidate]) -> list[Candidate]:
    """The candidates the oracle simulates: No Action, both Lift a Leg, and the steps nearest the
    coarse grid (one per grid node and swing foot)."""
    kept = [c for c in candidates if c.kind != "take_step"]
    for swing in ("left", "right"):
        steps = [c for c in candidates if c.kind == "take_step" and c.swing == swing and c.step is not None]
        for radius in ORACLE_RADII:
            for heading in np.radians(np.arange(0.0, 360.0, ORACLE_HEADING)):
                wanted = radius * np.array([math.cos(heading), math.sin(heading)])
                near = [c for c in steps if float(np.linalg.norm(c.step - wanted)) <= 0.05]
                if near:
                    best = min(near, key=lambda c: float(np.linalg.norm(c.step - wanted)))
                    if all(best is not k for k in kept):
                        kept.append(best)
    return kept


class _ServoState:
    """The servo parameters the rollouts overwrite in the shared model, restored afterwards."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.gain = model.actuator_gainprm.copy()
        self.bias = model.actuator_biasprm.copy()

    def restore(self) -> None:
        self.model.actuator_gainprm[:] = self.gain
        self.model.actuator_biasprm[:] = self.bias


def simulate(strategy: Any, data: mujoco.MjData, t: float, candidate: Candidate) -> tuple[float, bool]:
    """(fall direction, rad from the strategy's origin; whether the candidate's fall stops) of one
    candidate simulated from the present state `data` at time `t` (s); `data` is not changed.
    `strategy` is the running DirectionStrategy (not imported here: it imports this module)."""
    world, scenario = strategy.world, strategy.scenario
    model = world.model
    saved = {name: getattr(strategy, name) for name in SAVED}
    servo = _ServoState(model)
    copy = mujoco.MjData(model)
    mujoco.mj_copyData(copy, model, data)
    strategy.plan = Plan(candidate, "", None, [])
    strategy.step_done, strategy.swing_path, strategy.tracked = None, None, None
    strategy.q_ref, strategy.qd_ref = saved["q_ref"].copy(), saved["qd_ref"].copy()
    obstacle_columns = np.array([world.sensors[n].start for n in world.obstacle_sensors], dtype=int)
    push = scenario.push
    steps = scenario.physics_steps_per_control
    floor = strategy.config.touchdown_fraction * strategy.com_height
    now, end = t, t + ROLLOUT_LIMIT
    try:
        while now < end:
            state = RobotState.measure(strategy.P, *strategy.P.state(copy.qpos, copy.qvel))
            com = state.com
            if com[2] <= floor or (len(obstacle_columns) and (copy.sensordata[obstacle_columns] > 0).any()):
                break
            command = strategy._control(now, copy, state, capture_point(com, state.com_velocity))
            write_servo(model, copy, command)
            for _ in range(steps):
                if push is not None and not (push.start <= now < push.start + push.duration):
                    copy.xfrc_applied[:] = 0.0
                mujoco.mj_step(model, copy)
                now += scenario.physics_dt
        state = RobotState.measure(strategy.P, *strategy.P.state(copy.qpos, copy.qvel))
        delta = state.com[:2] - strategy.origin
        stopped = state.com[2] > floor and not (
            len(obstacle_columns) and (copy.sensordata[obstacle_columns] > 0).any()
        )
        return math.atan2(delta[1], delta[0]) % (2 * math.pi), bool(stopped)
    finally:
        for name, value in saved.items():
            setattr(strategy, name, value)
        servo.restore()
