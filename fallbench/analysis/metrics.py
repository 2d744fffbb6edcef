"""Every metric of a run, defined once, from the recorded time series (units in docs/results-and-metrics.md).

The IMU is the waist accelerometer: specific force in the waist frame, z up, so it reads
+9.81 m/s^2 standing still and 0 in free fall.
"""

from __future__ import annotations

import json
import math
import re
from functools import cache

import mujoco
import numpy as np
import pandas as pd

from fallbench.analysis.detection import detection_metrics
from fallbench.analysis.obstacles import com_path, fall_origin, obstacle_metrics
from fallbench.analysis.sensors import FORCE_WINDOW, ImuModel, window_mean_peak
from fallbench.dynamics.fall_direction import fall_class, horizontal_unit
from fallbench.scenario import Scenario
from fallbench.sim.events import METHODS
from fallbench.sim.impacts import first_impact_prescribed, head_before_hands, knees_simultaneous, touches
from fallbench.sim.recorder import Recording
from fallbench.sim.rest import rest_posture
from fallbench.sim.servo import pd_demand
from fallbench.sim.world import World

LIMIT_HIT_TOLERANCE = 1e-3  # rad past a joint limit that counts as hitting the stop
IMPULSE_WINDOW = 0.1  # s after the first impact over which the impulse is integrated
FELL_HEIGHT_FRACTION = 0.6  # base below this fraction of its standing height = fallen
SMOOTHING_WINDOW = 0.005  # s, moving average for the *_5ms IMU peaks
LANDING_WINDOW = 0.15  # s after the first impact: the landing that 002 Fig. 6 shows, before any later fall
SAFE_FIRST_GROUPS = {
    "hands",
    "feet",
}  # first impacts that can comply (000 Sec. III): not elbows, knees, torso, head
BODY_WEIGHT_GROUPS = ("total", "head", "torso")  # peak forces also given in body weights
# The damage measures the report ranks on and `fallbench converge` checks against the step.
HEADLINE_METRICS = (
    "imu_peak_z_landing",
    "contact_force_peak_head",
    "contact_force_peak_torso",
    "knee_limit_margin",
    "joint_limit_hits",
    "fell",
    "takeover_delay",
)
REPLAY_RATE = 100.0  # Hz at which the full qpos is kept in the time series, for rendering


def moving_average(signal: np.ndarray, samples: int) -> np.ndarray:
    if samples <= 1 or len(signal) < samples:
        return signal
    kernel = np.ones(samples) / samples
    return np.convolve(signal, kernel, mode="valid")


def _peak(signal: np.ndarray) -> float:
    return float(np.max(np.abs(signal))) if len(signal) else float("nan")


def imu_metrics(acc: np.ndarray, dt: float) -> dict[str, float]:
    """Peaks of the raw accelerometer, sampled at every physics step (m/s^2): they grow as the step
    shrinks and samples more of an impact's spike; kept beside the modelled IMU's peaks."""
    window = max(round(SMOOTHING_WINDOW / dt), 1)
    norm = np.linalg.norm(acc, axis=1)
    return {
        "imu_peak_z_raw": _peak(acc[:, 2]),
        "imu_peak_norm_raw": _peak(norm),
        "imu_peak_z_5ms": _peak(moving_average(acc[:, 2], window)),
        "imu_peak_norm_5ms": _peak(moving_average(norm, window)),
    }


def imu_model_metrics(
    samples_time: np.ndarray, samples: np.ndarray, impact: float | None
) -> dict[str, float]:
    """Peaks of the modelled IMU's output (m/s^2): over the run, and over the landing window."""
    window = landing_mask(samples_time, impact)
    norm = np.linalg.norm(samples, axis=1)
    return {
        "imu_peak_z": _peak(samples[:, 2]),
        "imu_peak_norm": _peak(norm),
        "imu_peak_z_landing": _peak(samples[window, 2]),
        "imu_peak_norm_landing": _peak(norm[window]),
    }


def landing_mask(time: np.ndarray, impact: float | None, length: float = LANDING_WINDOW) -> np.ndarray:
    """Samples in [impact, impact + length] (s); none without an impact."""
    if impact is None or not math.isfinite(impact):
        return np.zeros(len(time), dtype=bool)
    return (time >= impact - 1e-9) & (time <= impact + length + 1e-9)


def landing_metrics(
    time: np.ndarray,
    acc: np.ndarray,
    demand: np.ndarray,
    limit: np.ndarray,
    switch_time: np.ndarray,
    failure_times: list[float],
    impact: float | None,
    takeover: float | None,
    length: float = LANDING_WINDOW,
) -> dict[str, float]:
    """The landing window's raw IMU peaks (m/s^2, at the physics rate), PD demand / limit of the
    joints already under the gain policy (switch_time <= t), QP failures, and the delay from first
    contact to takeover (s)."""
    window = landing_mask(time, impact, length)
    under_policy = (switch_time[None, :] <= time[:, None] + 1e-9) & window[:, None]
    ratio = np.abs(demand) / limit
    failures = landing_mask(np.asarray(failure_times, dtype=float), impact, length)
    return {
        "imu_peak_z_landing_raw": _peak(acc[window, 2]),
        "imu_peak_norm_landing_raw": _peak(np.linalg.norm(acc[window], axis=1)),
        "torque_demand_ratio_landing": float(ratio[under_policy].max())
        if under_policy.any()
        else float("nan"),
        "qp_failures_landing": int(np.count_nonzero(failures)),
        "takeover_delay": float("nan") if impact is None or takeover is None else takeover - impact,
    }


def joint_limit_margins(q: np.ndarray, joint_range: np.ndarray) -> np.ndarray:
    """Distance to the nearest limit per sample and joint (rad); negative = past the limit."""
    return np.minimum(q - joint_range[:, 0], joint_range[:, 1] - q)


def torque_metrics(applied: np.ndarray, demand: np.ndarray, limit: np.ndarray, dt: float) -> dict[str, float]:
    saturated = np.abs(demand) > limit
    return {
        "torque_ratio_max": float(np.max(np.abs(applied) / limit)),
        "torque_demand_ratio_max": float(np.max(np.abs(demand) / limit)),
        "saturation_time": float(np.count_nonzero(saturated.any(axis=1)) * dt),
    }


def group_forces(rec: Recording) -> dict[str, np.ndarray]:
    """Norm of the net contact force (N) on each body group, and in total, per physics step."""
    world = rec.world
    forces = {"total": np.linalg.norm(world.sensor(rec.sensordata, "contact:total")[:, 1:4], axis=1)}
    for group, names in world.contact_groups.items():
        # the bodies' force columns gathered once from the wide sensor rows, then summed body after
        # body in place (reading them body by body took a third of the metrics' time)
        columns = [world.sensors[name].start + 1 + axis for name in names for axis in range(3)]
        block = rec.sensordata[:, columns]
        net = block[:, :3].copy()
        for first in range(3, len(columns), 3):
            net += block[:, first : first + 3]
        forces[group] = np.linalg.norm(net, axis=1)
    return forces


def first_contact_time(rec: Recording) -> float | None:
    """Physics-rate time of the impact the controller detected (its contact sensor reads it after that physics step)."""
    if rec.impact_time is None:
        return None
    world = rec.world
    columns = [world.contact_found_columns[world.contact_bodies.index(b)] for b in rec.impact_bodies]
    after_fall = rec.time >= (rec.fall_time or 0.0)
    touching = (rec.sensordata[:, columns] > 0).any(axis=1) & after_fall
    return float(rec.time[np.argmax(touching)]) if touching.any() else rec.impact_time


def fall_class_at_impact(rec: Recording) -> tuple[float, str]:
    """(fall direction, deg in the world frame, and front/back/left/right against the waist's
    heading at detection): the way the waist's z axis leans at the first impact."""
    if rec.fall_time is None or not rec.impact_events:
        return float("nan"), ""
    at_fall = int(np.searchsorted(rec.time, rec.fall_time))
    at_impact = min(int(np.searchsorted(rec.time, rec.impact_events[0].t)), len(rec.time) - 1)
    rotations = []
    for at in (at_fall, at_impact):
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, rec.world.sensor(rec.sensordata[at], "base_quat"))
        rotations.append(rotation.reshape(3, 3))
    lean = horizontal_unit(rotations[1][:, 2])
    if lean is None:
        return float("nan"), ""
    return math.degrees(math.atan2(lean[1], lean[0])), fall_class(lean, rotations[0])


def fall_lead_times(rec: Recording, impact: float | None) -> dict[str, float]:
    """When each fall detector fired (s, NaN if it did not before the first impact), and the lead
    time (s) from the declared detection, and from each detector, to the first impact."""
    row = {}

    def lead(fired: float | None) -> float:
        return float("nan") if impact is None or fired is None else impact - fired

    row["fall_lead_time"] = lead(rec.fall_time)
    for method in METHODS:
        fired = rec.fall_times.get(method)
        row[f"fall_time_{method}"] = float("nan") if fired is None else float(fired)
        row[f"fall_lead_time_{method}"] = lead(fired)
    return row


def impact_metrics(rec: Recording) -> dict[str, object]:
    """Order of the body groups' first impacts, and the arms and singular joints at the first."""
    events = rec.impact_events
    row: dict[str, object] = {
        "impact_events": json.dumps(
            [
                {
                    "t": round(e.t, 4),
                    "group": e.group,
                    "bodies": e.bodies,
                    "elbow_rad": {k: round(v, 4) for k, v in e.elbow_angles.items()},
                    "singular": e.singular,
                }
                for e in events
            ]
        )
    }
    row["impact_order"] = ">".join(e.group for e in events)
    first = [e for e in events if events and e.t == events[0].t]
    row["first_impact_group"] = "+".join(e.group for e in first)
    row["first_impact_safe"] = bool(first) and {e.group for e in first} <= SAFE_FIRST_GROUPS
    row["time_to_first_impact"] = (
        float(events[0].t - rec.fall_time) if events and rec.fall_time is not None else float("nan")
    )
    for side in ("left", "right"):
        row[f"elbow_angle_first_impact_{side}"] = (
            float(first[0].elbow_angles.get(side, np.nan)) if first else float("nan")
        )
    singular = sorted({j for e in first for j in e.singular})
    row["singular_joints_first_impact"] = len(singular)
    row["singular_joints_first_impact_names"] = ",".join(singular)
    row["fall_direction_deg"], row["fall_class"] = fall_class_at_impact(rec)
    landing = touches(rec.world, rec.contact_times)
    row["first_impact_prescribed"] = first_impact_prescribed(landing, str(row["fall_class"]))
    row["knees_simultaneous"] = knees_simultaneous(landing)
    row["head_before_hands"] = head_before_hands(landing)
    return row


def damage_metrics(
    rec: Recording, forces: dict[str, np.ndarray], dt: float, force_window: float = FORCE_WINDOW
) -> dict[str, float]:
    """Damage measures as the learned fall-control literature reports them (SafeFall: peak contact
    force, peak joint torque, hits on vulnerable parts): peak forces (mean over `force_window` s) in
    body weights (m g), the peak applied torque per joint chain (Nm), and how many vulnerable parts
    touched the environment."""
    world = rec.world
    weight = float(world.model.body_subtreemass[world.root_body]) * 9.81
    row: dict[str, float] = {}
    for group in BODY_WEIGHT_GROUPS:
        name = "contact_force_peak" + ("" if group == "total" else f"_{group}")
        row[f"{name}_bw"] = (
            window_mean_peak(forces[group], dt, force_window) / weight
            if group in forces and len(forces[group])
            else float("nan")
        )
    for chain, pattern in world.robot.torque_chains.items():
        joints = chain_joints(world.joint_names, pattern)
        row[f"torque_peak_{chain}"] = (
            float(np.abs(rec.actuator_force[:, joints]).max()) if joints and rec.steps else float("nan")
        )
    counts = rec.sensordata[:, world.contact_found_index]  # contacts found, per body
    found = (counts > 0).any(axis=0)  # per contact body
    touched = {body for body, touching in zip(world.contact_bodies, found) if touching}
    row["vulnerable_hits"] = sum(
        bool(touched & set(bodies)) for bodies in world.robot.vulnerable_parts.values()
    )
    return row


@cache
def chain_joints(joint_names: tuple[str, ...], pattern: str) -> tuple[int, ...]:
    """Indices of the joints whose names match a torque chain's pattern (the same for every run of
    a robot: matched once)."""
    return tuple(j for j, name in enumerate(joint_names) if re.fullmatch(pattern, name))


def replay_columns(rec: Recording) -> dict[str, np.ndarray]:
    """The full qpos every 1/REPLAY_RATE s (NaN between samples): what `fallbench render` replays."""
    every = max(round(1.0 / (REPLAY_RATE * rec.scenario.physics_dt)), 1)
    sampled = np.full(rec.qpos.shape, np.nan)
    sampled[::every] = rec.qpos[::every]
    return {f"qpos:{i}": sampled[:, i] for i in range(rec.qpos.shape[1])}


def compute_metrics(rec: Recording, forces: dict[str, np.ndarray] | None = None) -> dict[str, object]:
    """One run's row: sensor peaks, joints and torques, the landing, timing, outcome and the
    controllers' own statistics (`forces`: `group_forces(rec)`, if already computed)."""
    impact = first_contact_time(rec)
    switched = rec.switch_time[np.isfinite(rec.switch_time)]
    takeover = float(switched.min()) if len(switched) else None  # s: the first motor under the policy
    forces = group_forces(rec) if forces is None else forces
    row: dict[str, object] = {}
    row.update(_imu_and_joints(rec, impact, takeover))
    row.update(_forces(rec, forces, impact))
    row["impact_time"] = float("nan") if impact is None else impact
    row["policy_switch_time"] = float("nan") if takeover is None else takeover
    row["fall_time"] = float("nan") if rec.fall_time is None else float(rec.fall_time)
    row["fall_reason"] = rec.fall_reason
    row.update(fall_lead_times(rec, impact))
    row.update(_detection(rec))
    for name in ("strategy_start_time", "hand_back_time"):
        value = getattr(rec, name)
        row[name] = float("nan") if value is None else float(value)
    row["first_contact_bodies"] = ",".join(rec.impact_bodies)
    row.update(_outcome(rec))
    row["controller_ms_median"] = float(np.median(rec.controller_ms))
    row.update(impact_metrics(rec))
    row.update(_controller_statistics(rec, row))
    row["sim_steps"] = int(rec.steps)
    row["sim_time"] = float(rec.steps * rec.scenario.physics_dt)
    return row


def _detection(rec: Recording) -> dict[str, object]:
    """Every detector's firing time over the threshold grid (analysis/detection.py)."""
    push = rec.scenario.push
    onset = push.start if push is not None and push.force != 0 else 0.0
    hold = rec.scenario.detection.freefall_hold
    return detection_metrics(rec.detection_signals, rec.body_contact_time, onset, hold)


def _imu_and_joints(rec: Recording, impact: float | None, takeover: float | None) -> dict[str, object]:
    """The modelled and raw IMU peaks, joint limits, torques and the landing window."""
    world, scenario, dt = rec.world, rec.scenario, rec.scenario.physics_dt
    q, qd = rec.qpos[:, world.qpos_adr], rec.qvel[:, world.qvel_adr]
    margins = joint_limit_margins(q, world.joint_range)
    knees = [world.joint_names.index(j) for j in world.robot.knee_joints]
    demand = pd_demand(rec.kp, rec.kd, rec.q_ref, rec.qd_ref, q, qd)
    acc = world.sensor(rec.sensordata, "imu_acc")
    sensors = scenario.sensors
    imu = ImuModel(sensors.imu_rate, sensors.imu_bandwidth, sensors.imu_filter_order)
    row: dict[str, object] = {}
    row.update(imu_model_metrics(*imu.read(rec.time, acc), impact))
    row.update(imu_metrics(acc, dt))
    row["knee_limit_margin"] = float(margins[:, knees].min())
    row["joint_limit_hits"] = int(np.count_nonzero((margins < -LIMIT_HIT_TOLERANCE).any(axis=0)))
    row.update(torque_metrics(rec.actuator_force, demand, world.torque_limit, dt))
    limit, failures = world.torque_limit, rec.policy_failure_times
    row.update(landing_metrics(rec.time, acc, demand, limit, rec.switch_time, failures, impact, takeover))
    return row


def _forces(rec: Recording, forces: dict[str, np.ndarray], impact: float | None) -> dict[str, object]:
    """Peak contact forces (windowed, N; per step as `*_raw`), damage measures, impulse and impact speed."""
    world, dt, window = rec.world, rec.scenario.physics_dt, rec.scenario.sensors.force_window
    row: dict[str, object] = {}
    for group, force in forces.items():
        name = "contact_force_peak" + ("" if group == "total" else f"_{group}")
        row[name] = window_mean_peak(force, dt, window)
        row[f"{name}_raw"] = float(force.max())
    row.update(damage_metrics(rec, forces, dt, window))
    if impact is None:
        return row | {"impulse": float("nan"), "impact_speed": float("nan")}
    after = (rec.time >= impact) & (rec.time < impact + IMPULSE_WINDOW)
    row["impulse"] = float(forces["total"][after].sum() * dt)
    at = int(np.searchsorted(rec.time, impact))
    row["impact_speed"] = float(np.linalg.norm(world.sensor(rec.sensordata[at], "base_linvel")))
    return row


def fell_height(world: World, scenario: Scenario, start_height: float) -> float:
    """Root height (m) below which a run ends fallen: FELL_HEIGHT_FRACTION x the root's standing
    height in the scenario's posture (the run's first root height for a posture without one)."""
    standing = world.robot.posture_base_height.get(scenario.initial.posture, start_height)
    return FELL_HEIGHT_FRACTION * standing


def _outcome(rec: Recording) -> dict[str, object]:
    """Whether the run came to rest and when, its final height and posture, whether the robot fell
    (read at rest), and what it did to the obstacles."""
    world = rec.world
    base_height = rec.qpos[:, 2]
    fallen_below = fell_height(world, rec.scenario, float(base_height[0]))
    obstacle_force = [
        np.linalg.norm(world.sensor(rec.sensordata, n)[:, 1:4], axis=1) for n in world.obstacle_sensors
    ]
    fell = bool(base_height[-1] < fallen_below)
    return {
        "settled": rec.time_to_rest is not None,
        "time_to_rest": float("nan") if rec.time_to_rest is None else rec.time_to_rest,
        "rest_posture": rest_posture(rec.rest_frame, fell),
        "final_base_height": float(base_height[-1]),
        "fell": fell,
        "obstacle_contacts": int(sum(bool((f > 0).any()) for f in obstacle_force)),
        "obstacle_force_peak": float(max((f.max() for f in obstacle_force), default=0.0)),
    }


def _controller_statistics(rec: Recording, row: dict[str, object]) -> dict[str, object]:
    """The policy's and strategy's own statistics over the columns every row has (what every
    registered controller declared, `Recording.stat_columns`), and the outcome among objects."""
    stats: dict[str, object] = dict(rec.stat_columns) | rec.policy_stats
    if rec.strategy is not None:
        stats.update(rec.strategy.metrics(rec))
    if rec.scenario.obstacles:
        stats.update(obstacle_metrics(rec, fall_origin(stats, rec)))
    return stats


def timeseries(rec: Recording, forces: dict[str, np.ndarray] | None = None) -> pd.DataFrame:
    """The signals the paper figures need, at the physics rate, float32 (`forces`: as in compute_metrics)."""
    world = rec.world
    acc = world.sensor(rec.sensordata, "imu_acc")
    columns: dict[str, np.ndarray] = {
        "t": rec.time,
        "imu_acc_x": acc[:, 0],
        "imu_acc_y": acc[:, 1],
        "imu_acc_z": acc[:, 2],
    }
    for axis, i in zip("xyz", range(3)):
        columns[f"base_{axis}"] = rec.qpos[:, i]
    for joint in world.robot.timeseries_joints:
        j = world.joint_names.index(joint)
        columns[f"q:{joint}"] = rec.qpos[:, world.qpos_adr[j]]
        columns[f"tau:{joint}"] = rec.actuator_force[:, j]
    for group, force in (group_forces(rec) if forces is None else forces).items():
        columns[f"force:{group}"] = force
    if rec.scenario.obstacles:  # for the top-down plots of falls among objects (004)
        com = com_path(rec)
        columns.update({"com_x": com[:, 0], "com_y": com[:, 1], "com_z": com[:, 2]})
    legs = set(world.robot.leg_joints)
    for j, joint in enumerate(world.joint_names):
        if joint in legs:
            columns[f"K:{joint}"] = rec.kp[:, j]
            columns[f"B:{joint}"] = rec.kd[:, j]
    columns.update(replay_columns(rec))
    # one float32 block filled column by column (the same cast as np.asarray's): a frame built from
    # ~100 separate columns spent ~0.6 ms a run in pandas' checks of each
    block = np.empty((len(columns), len(rec.time)), dtype=np.float32)
    for row, values in zip(block, columns.values()):
        row[:] = values
    return pd.DataFrame(block.T, columns=list(columns), copy=False)
