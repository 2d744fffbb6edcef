"""The control loop of one fall and the recorder of its time series.

Physics at `physics_dt`, controller every `control_dt`: state -> fall detector -> pre-impact
strategy -> impact detector -> gain policy -> servo references and gains written into the
actuators. Everything the metrics need is recorded at the physics rate from MuJoCo's sensors
(computed in C inside the step).

Every motor switches to the gain policy at the first impact, unless the pre-impact strategy
switches per chain (`reshape`): then a motor switches when a body on its chain to the root touches
the environment (002 Sec. V, last paragraph); the others go on reshaping until the torso or head
lands, when all switch. Contacts the strategy planned (a footstep) are not impacts.

Impacts are watched inside the physics substeps: after fall detection, and until every motor has
switched, a body touching for the first time (its contact sensor's "found" column) ends the substeps
and runs a control step at once, so the policy takes over one physics step after first contact
instead of at the next 5 ms control step. The regular control grid then resumes.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.events import (CapturePointDetector, FallDetector, FreefallDetector, ImpactDetector,
                              TiltDetector)
from fallbench.impacts import ImpactEvent, ImpactLog
from fallbench.policies import GainPolicy, Observation, make_policy
from fallbench.policies.stiff import gain_scale
from fallbench.preimpact import Strategy, make_strategy
from fallbench.scenario import Scenario
from fallbench.servo import ServoCommand, write_servo
from fallbench.support import FootSupport
from fallbench.world import World, build_world, initial_state

LANDED_GROUPS = ("torso", "head")  # a contact here ends pre-impact reshaping for every motor
DIVERGENCE_WARNINGS = np.array([int(mujoco.mjtWarning.mjWARN_BADQACC), int(mujoco.mjtWarning.mjWARN_BADQVEL),
                                int(mujoco.mjtWarning.mjWARN_BADQPOS)])


# Divergence is read from data.warning and stored with the run; MuJoCo's own printout (and its
# MUJOCO_LOG.TXT in the working folder) would only clutter a sweep's output.
mujoco.set_mju_user_warning(lambda message: None)


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
    impact_events: list[ImpactEvent] = field(default_factory=list)  # first contact of each body group, in order
    contact_times: dict[str, float] = field(default_factory=dict)  # s, first contact of each body after the fall was detected
    landing_errors: dict[str, float] = field(default_factory=dict)  # m per arm side, chosen BIP to wrist contact
    policy_stats: dict[str, float] = field(default_factory=dict)
    strategy: Strategy | None = None  # the pre-impact strategy, for its own metrics
    policy_failure_times: list[float] = field(default_factory=list)  # s, control steps whose policy QP failed
    steps: int = 0
    status: str = "ok"
    error: str = ""


def _found(world: World, sensor_rows: np.ndarray) -> np.ndarray:
    """Per contact body: whether its contact sensor found a contact in any of these sensor rows."""
    return np.take(sensor_rows, world.contact_found_columns, axis=1).max(axis=0) > 0


def _names(world: World, mask: np.ndarray) -> set[str]:
    return {world.contact_bodies[i] for i in np.flatnonzero(mask)}


def _held(changes: list[tuple[int, ServoCommand]], n_steps: int, nu: int) -> np.ndarray:
    """(4, n_steps, nu) kp, kd, q_ref, qd_ref per physics step from the steps where they changed."""
    gains = np.empty((4, n_steps, nu))
    ends = [k for k, _ in changes[1:]] + [n_steps]
    for (start, command), end in zip(changes, ends):
        gains[:, start:end] = np.stack([command.kp, command.kd, command.q_ref, command.qd_ref])[:, None, :]
    return gains


def _push_force(world: World, scenario: Scenario) -> tuple[int, np.ndarray] | None:
    push = scenario.push
    if push is None or push.force == 0:
        return None
    body = world.model.body(push.body or world.robot.torso_body).id
    heading = math.radians(push.direction)
    force = push.force * np.array([math.cos(heading), math.sin(heading), 0.0])
    return body, np.concatenate([force, np.zeros(3)])


def _compose(switched: np.ndarray, policy: ServoCommand, other: ServoCommand) -> ServoCommand:
    """Switched motors follow the gain policy, the others the pre-impact command."""
    if switched.all():
        return policy
    return ServoCommand(*(np.where(switched, a, b) for a, b in zip(
        (policy.kp, policy.kd, policy.q_ref, policy.qd_ref), (other.kp, other.kd, other.q_ref, other.qd_ref))))


def make_fall_detector(scenario: Scenario) -> FallDetector:
    detection = scenario.detection
    return FallDetector(detection.method, CapturePointDetector(detection.capture_point_margin),
                        TiltDetector(detection.tilt), FreefallDetector(detection.freefall, detection.freefall_hold))


def _with_baseline_gains(world: World, scenario: Scenario) -> World:
    """The world with its default gains times `policy_params.stiff.gain_scale`: the baseline
    stiffness that every policy uses before impact (and `stiff` after)."""
    scale = gain_scale(scenario)
    if scale == 1.0:
        return world
    return dataclasses.replace(world, default_kp=world.default_kp * scale, default_kd=world.default_kd * scale)


def _failure_times(policy: GainPolicy) -> list[float]:
    """Control steps (s) whose QP failed, from a QP policy's per-step records (if it keeps them)."""
    return [float(r["t"]) for r in getattr(policy, "records", ()) if r.get("qp_solved", 1.0) == 0.0]


def run_episode(scenario: Scenario, policy_name: str, pre_impact: str = "none") -> Recording:
    world = _with_baseline_gains(build_world(scenario), scenario)
    model = world.model
    policy: GainPolicy = make_policy(policy_name, world, scenario)
    strategy = make_strategy(pre_impact, world, scenario)
    data = initial_state(world, scenario)
    impacts = ImpactLog(world)
    P = pinocchio_for(world)
    landed_bodies = {b for g in LANDED_GROUPS for b in world.robot.body_groups.get(g, ())}

    per_control = scenario.physics_steps_per_control
    n_steps = math.ceil(scenario.duration / scenario.control_dt - 1e-9) * per_control
    rec_sensor = np.zeros((n_steps, model.nsensordata))
    rec_qpos = np.zeros((n_steps, model.nq))
    rec_qvel = np.zeros((n_steps, model.nv))
    rec_force = np.zeros((n_steps, model.nu))
    controller_ms: list[float] = []

    q_start = data.qpos[world.qpos_adr].copy()
    command = pre_command = ServoCommand(world.default_kp, world.default_kd, q_start, np.zeros(model.nu))
    switched = np.zeros(model.nu, dtype=bool)  # motors under the gain policy
    switch_time = np.full(model.nu, np.nan)
    fall = make_fall_detector(scenario)
    support = FootSupport(world)
    impact = ImpactDetector()
    q_ref_impact: np.ndarray | None = None
    push = _push_force(world, scenario)
    torso_rotation = np.zeros(9)
    write_servo(model, data, command)  # before the first forward pass: the cached model holds the last episode's gains
    written, changes = command, [(0, command)]  # (physics step, command) where the servo changed
    mujoco.mj_forward(model, data)
    sensor_row = data.sensordata.copy()
    status, error, step, physics_s = "ok", "", 0, 0.0
    # Views into MjData bound once: each attribute access would build a new array wrapper.
    qpos, qvel, sensordata, actuator_force = data.qpos, data.qvel, data.sensordata, data.actuator_force
    qacc, warning_counts = data.qacc, data.warning.number
    seen = np.zeros(len(world.contact_bodies), dtype=bool)  # bodies in contact at detection or since
    unplanned: np.ndarray | bool = True  # bodies whose contact would be an impact (not a planned footstep)
    since = 0  # physics step of the previous control step

    def recent_found() -> np.ndarray:
        return _found(world, rec_sensor[since:step] if step else sensor_row[None])

    policy_command: ServoCommand | None = None
    while step < n_steps:
        t = step * scenario.physics_dt
        started = time.perf_counter()
        if impact.time is None and not fall.all_fired:  # every detector watched until the first impact
            detected = fall.time is not None
            found_now = recent_found()
            mujoco.mju_copy(torso_rotation, data.xmat[world.torso_body])
            if fall.update(t, world.robot.torso_frame(torso_rotation.reshape(3, 3)), world.sensor(sensor_row, "imu_acc"),
                           world.sensor(sensor_row, "com_pos"), world.sensor(sensor_row, "com_vel"),
                           support.points(data, found_now)) and not detected:
                seen = found_now
                impact.start(_names(world, seen))
                strategy.start(t, data)
        switch_changed = False
        found = recent_found() if fall.time is not None else seen
        if fall.time is not None:
            planned = strategy.planned_contacts()
            unplanned = ~np.isin(world.contact_bodies, list(planned)) if planned else True  # a planned footstep is not an impact
            fresh = found & ~seen & unplanned
            if fresh.any():  # bodies touching for the first time since the fall was detected
                seen |= fresh
                new = _names(world, fresh)
                impact.update(t, new)
                impacts.update(t, new, data, qpos, qvel)
                if impact.time is not None and not switched.all():
                    now = np.ones(model.nu, dtype=bool) if not strategy.per_chain_switching or new & landed_bodies else switched.copy()
                    now[select_motors(P, new, world.joint_names)] = True
                    if (now & ~switched).any():
                        q = qpos[world.qpos_adr]
                        q_ref_impact = np.where(now & ~switched, q, q_ref_impact if q_ref_impact is not None else q)
                        switch_time[now & ~switched] = t
                        switched, switch_changed = now, True
            if not switched.all() and step % per_control == 0:  # the strategy's own 5 ms grid
                pre_command = strategy.step(t, data) or pre_command
        if switched.any():
            if switch_changed or not policy.static or policy_command is None:
                q, qd = qpos[world.qpos_adr], qvel[world.qvel_adr]
                touching_now = _names(world, found) if policy.needs_contacts else set()
                observation = Observation(t, qpos.copy(), qvel.copy(), q, qd, touching_now, data)
                assert q_ref_impact is not None
                policy_command = policy.after_impact(observation, q_ref_impact)
            command = _compose(switched, policy_command, pre_command)
        else:
            command = pre_command
        controller_ms.append((time.perf_counter() - started) * 1e3 if fall.time is not None else 0.0)
        if command is not written:
            write_servo(model, data, command)
            written = command
            changes.append((step, command))
        if push is not None:
            active = scenario.push.start <= t < scenario.push.start + scenario.push.duration
            data.xfrc_applied[push[0]] = push[1] if active else 0.0

        since = step
        # until every motor has switched, a body touching for the first time ends the substeps at once
        watched = world.contact_found_columns[~seen & unplanned] if fall.time is not None and not switched.all() else None
        for _ in range(per_control - step % per_control):
            rec_qpos[step] = qpos
            rec_qvel[step] = qvel
            stepped = time.perf_counter()
            mujoco.mj_step(model, data)
            physics_s += time.perf_counter() - stepped
            # sensors and actuator forces are computed inside the step, from the state before it
            rec_sensor[step] = sensordata
            rec_force[step] = actuator_force
            step += 1
            if watched is not None and sensordata[watched].any():
                break
        sensor_row = rec_sensor[step - 1]
        if warning_counts[DIVERGENCE_WARNINGS].any() or not math.isfinite(qacc.sum()):  # a NaN or inf anywhere
            status = "diverged"
            error = ", ".join(mujoco.mjtWarning(w).name for w in DIVERGENCE_WARNINGS if warning_counts[w]) or "non-finite state"
            break

    held = _held(changes, step, model.nu)
    landing_errors: dict[str, float] = {}
    for side in world.robot.arms:
        contact = impacts.side_first_contact(side)
        target = strategy.landing_target(side, contact[1].t) if contact else None
        if contact is not None and target is not None:
            landing_errors[side] = float(np.linalg.norm(contact[1].point - target))
    return Recording(
        world=world, scenario=scenario, time=np.arange(step) * scenario.physics_dt, sensordata=rec_sensor[:step],
        qpos=rec_qpos[:step], qvel=rec_qvel[:step], actuator_force=rec_force[:step],
        kp=held[0], kd=held[1], q_ref=held[2], qd_ref=held[3],
        fall_time=fall.time, fall_reason=fall.reason, fall_times=dict(fall.times), impact_time=impact.time, impact_bodies=impact.bodies,
        controller_ms=np.array(controller_ms), physics_s=physics_s, pre_impact=pre_impact, impact_events=impacts.events,
        contact_times={body: contact.t for body, contact in impacts.first_contacts.items()},
        landing_errors=landing_errors, policy_stats=policy.stats() | strategy.stats(), strategy=strategy,
        switch_time=switch_time, policy_failure_times=_failure_times(policy), steps=step, status=status, error=error,
    )
