"""The oracle predictor (`policy_params.direction.predictor: oracle`): every
candidate's fall direction is found by simulating that candidate in a copy of the scene, from the
control trigger to the fall's end, instead of by 004's inverted pendulum. A perfect prediction, not
a real-time one (it costs seconds of planning per fall): it bounds what `direction` could reach with
its candidates if prediction were free, separating prediction's cost from the robot's authority.

Each rollout runs the candidate alone (no inertia shaping, no tracking: what the pendulum predicts
too) with the strategy's own swing control and servo, the push as scheduled, and ends at
touchdown (the CoM down to `touchdown_fraction` of its standing height), at the first contact with
an object (then the object sets the direction, as in `fallbench.analysis.obstacles`), or `ROLLOUT_LIMIT` s. The
stepping grid is coarser than the pendulum's (`ORACLE_RADII` x every `ORACLE_HEADING` deg) to keep
the rollouts to a few dozen per fall.

`run_candidate` is the machinery the short-rollout predictor (rollout.py) shares: it simulates a
candidate in a copy of the state and of the model, and puts the strategy back as it was (the
strategy's `snapshot()` and `restore()`).
"""

from __future__ import annotations

import copy as copying
import math
from collections.abc import Callable, Iterable
from typing import Any

import mujoco
import numpy as np

from fallbench.dynamics.state import RobotState
from fallbench.preimpact.direction.candidates import Candidate
from fallbench.sim.events import capture_point
from fallbench.sim.scene import obstacle_geoms
from fallbench.sim.servo import write_servo

ROLLOUT_LIMIT = 2.0  # s after the control trigger
ORACLE_RADII = (0.25, 0.45)  # m, step lengths simulated
ORACLE_HEADING = 45.0  # deg between simulated step headings


def step_subset(candidates: list[Candidate], radii: Iterable[float], heading_deg: float) -> list[Candidate]:
    """No Action, both Lift a Leg, and the steps nearest a coarse grid (`radii` m x every
    `heading_deg` deg; one per grid node and swing foot, within 0.05 m of it)."""
    kept = [c for c in candidates if c.kind != "take_step"]
    for swing in ("left", "right"):
        steps = [c for c in candidates if c.kind == "take_step" and c.swing == swing and c.step is not None]
        for radius in radii:
            for heading in np.radians(np.arange(0.0, 360.0, heading_deg)):
                wanted = radius * np.array([math.cos(heading), math.sin(heading)])
                near = [c for c in steps if float(np.linalg.norm(c.step - wanted)) <= 0.05]
                if near:
                    best = min(near, key=lambda c: float(np.linalg.norm(c.step - wanted)))
                    if all(best is not k for k in kept):
                        kept.append(best)
    return kept


def oracle_subset(candidates: list[Candidate]) -> list[Candidate]:
    """The candidates the oracle simulates: `step_subset` at `ORACLE_RADII` x every `ORACLE_HEADING` deg."""
    return step_subset(candidates, ORACLE_RADII, ORACLE_HEADING)


Stop = Callable[[mujoco.MjData, RobotState], bool]  # (the copy, its state) -> end the rollout now


def run_candidate(
    strategy: Any,
    data: mujoco.MjData,
    t: float,
    candidate: Candidate,
    limit: float,
    stop: Stop,
    *,
    push: bool = True,
    objects: bool = True,
    physics_dt: float = 0.0,
) -> tuple[mujoco.MjData, RobotState, float]:
    """(the copy, its state, its time s) after simulating `candidate` alone (no inertia shaping) with
    the strategy's own swing control and servo, from the present state `data` at time `t` (s) until
    `stop` says so or `limit` s have passed. `push`: the scenario's push as scheduled (else none);
    `objects`: the objects collide (else they are not there); `physics_dt` (s): the rollout's
    physics step, if not 0 (else the scenario's). The rollout steps a copy of the run's model, so
    the run's model is not written; `data`, the strategy's state (its `snapshot()`, put back by
    `restore()`) and the kinematics in the strategy's Pinocchio data are left as they were.
    `strategy` is the running DirectionStrategy (not imported here: it imports this module)."""
    world, scenario = strategy.world, strategy.scenario
    model = copying.copy(world.model)  # the rollout's own: its gains, objects and step are its own
    saved = strategy.snapshot()
    copy = mujoco.MjData(model)
    mujoco.mj_copyData(copy, world.model, data)
    if not objects:  # the objects stop colliding with anything (a robot that knows them only as circles)
        model.geom_contype[obstacle_geoms(model)] = 0
        model.geom_conaffinity[obstacle_geoms(model)] = 0
    strategy.rehearse(candidate)
    scheduled = scenario.push if push else None
    steps, dt = scenario.physics_steps_per_control, scenario.physics_dt
    if physics_dt > 0.0:
        model.opt.timestep = dt = physics_dt
        steps = max(round(scenario.control_dt / dt), 1)
    now, end = t, t + limit
    try:
        state = RobotState.measure(strategy.P, *strategy.P.state(copy.qpos, copy.qvel))
        while now < end and not stop(copy, state):
            command = strategy._control(now, copy, state, capture_point(state.com, state.com_velocity))
            write_servo(model, copy, command)
            for _ in range(steps):
                if scheduled is None or not (scheduled.start <= now < scheduled.start + scheduled.duration):
                    copy.xfrc_applied[:] = 0.0
                mujoco.mj_step(model, copy)
                now += dt
            state = RobotState.measure(strategy.P, *strategy.P.state(copy.qpos, copy.qvel))
        return copy, state, now
    finally:
        strategy.restore(saved)
        # Pinocchio's data: the kinematics of the present state again
        RobotState.measure(strategy.P, *strategy.P.state(data.qpos, data.qvel))


def simulate(strategy: Any, data: mujoco.MjData, t: float, candidate: Candidate) -> tuple[float, bool]:
    """(fall direction, rad from the strategy's origin; whether the candidate's fall stops) of one
    candidate simulated, with the objects and the push, from the present state `data` at time `t`
    (s) to the fall's end; `data` is not changed."""
    world = strategy.world
    obstacle_columns = np.array([world.sensors[n].start for n in world.obstacle_sensors], dtype=int)
    floor = strategy.config.touchdown_fraction * strategy.com_height

    def touching(copy: mujoco.MjData) -> bool:
        return bool(len(obstacle_columns) and (copy.sensordata[obstacle_columns] > 0).any())

    def ended(copy: mujoco.MjData, state: RobotState) -> bool:
        return bool(state.com[2] <= floor) or touching(copy)

    copy, state, _ = run_candidate(strategy, data, t, candidate, ROLLOUT_LIMIT, ended)
    delta = state.com[:2] - strategy.origin
    stopped = state.com[2] > floor and not touching(copy)
    return math.atan2(delta[1], delta[0]) % (2 * math.pi), bool(stopped)
