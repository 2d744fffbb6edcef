"""The `reshape` pre-impact strategy (002 Sec. IV, 000 Sec. IV): from fall detection to impact.

Each control step: fall direction (eq. 2) and class, landing points for both wrists (MPIP/BIP),
then the whole-body QP with the reshaping tasks. The robot is position controlled, so the QP's
joint accelerations are integrated into the servo references (q_ref, qd_ref), held by the
default stiff gains.

Tasks: torso lateral axis perpendicular to the fall direction (vector orientation: the robot
turns to a front or back fall, whichever is nearer); each wrist toward its BIP along the surface
(surface position); both wrists at the same distance from their surfaces (relative distance);
the fall posture (bent knees, elbows at highest manipulability, hands pulled up).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from fallbench.control.adaptive_gains_qp import model_terms
from fallbench.dynamics.contacts import environment_contacts
from fallbench.dynamics.dense_qp import DenseQP
from fallbench.control.fall_direction import FallDirection, fall_class, heading
from fallbench.control.fall_posture import fall_posture
from fallbench.control.landing import Candidate, choose, landing_candidates
from fallbench.dynamics.model import pinocchio_for
from fallbench.control.reach import reach_polyhedra
from fallbench.control.reshape_qp import SetPoint, build_reshape_problem
from fallbench.control.surfaces import scene_surfaces
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.com import ComTask
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask
from fallbench.scenario import Scenario
from fallbench.servo import ServoCommand
from fallbench.world import World

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ReshapeConfig:
    """Task weights and gains of the reshaping QP (documented in the README)."""

    w_orientation: float = 10.0
    w_landing: float = 10.0  # each wrist toward its BIP, along the surface
    w_relative_distance: float = 10.0
    w_posture: float = 1.0
    task_kp: float = 40.0  # 1/s^2, every task
    task_kv: float = 12.6  # 1/s, critically damped for task_kp
    knee_bend: float = 1.6  # rad, knee target of the fall posture
    w_lambda: float = 1e-6
    w_qdd: float = 1e-4
    w_contact: float = 100.0  # contact points neither sinking in nor lifting off (a cost, not a constraint)
    eps_abs: float = 1e-6
    # Iteration caps bound the solver's rare very long solves (seen: 49 s with ProxSuite's
    # defaults); a capped solve counts as a failure and the references coast for that step.
    max_iter: int = 200
    max_iter_in: int = 100


@dataclass
class Landing:
    t: float
    side: str
    candidate: Candidate


class ReshapeController:
    """The reshaping controller of one episode: `start` at fall detection, then `step` per control step."""

    def __init__(self, world: World, scenario: Scenario, params: dict[str, Any] | None = None) -> None:
        self.world, self.scenario = world, scenario
        self.cfg = ReshapeConfig(**(params or {}))
        self.P = pinocchio_for(world)
        robot = world.robot
        self.reach = reach_polyhedra(robot, self.P.model)
        self.surfaces = scene_surfaces(scenario)
        start = {**robot.postures[scenario.initial.posture], **scenario.initial.joints}
        start = {j: start.get(j, 0.0) for j in world.joint_names}
        target = fall_posture(self.P.model, robot, start, self.cfg.knee_bend)
        self.posture = PostureTask(np.array([target[j] for j in world.joint_names]), self.P.actuated_v, self.P.model.nv)
        self.wrists = {side: BodyPoint(arm.wrist_frame, np.zeros(3)) for side, arm in robot.arms.items()}
        self.qp = DenseQP(self.cfg.eps_abs, self.cfg.max_iter, self.cfg.max_iter_in)
        self.direction: FallDirection | None = None
        self.q_ref = self.qd_ref = np.zeros(world.model.nu)
        self.landings: list[Landing] = []
        self.classes: list[str] = []
        self.step_ms: list[float] = []
        self.failures = 0

    def start(self, qpos: np.ndarray, qvel: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """At fall detection: references from the measured joints, CoM for the fall direction."""
        pq, pv = self.P.state(qpos, qvel)
        self.direction = FallDirection(ComTask.state(self.P.model, self.P.data, pq, pv)[0])
        self.q_ref, self.qd_ref = q.copy(), qd.copy()

    def _landing_tasks(self, t: float, direction: np.ndarray, facing: str, torso_rotation: np.ndarray,
                       support: np.ndarray) -> list[SetPoint]:
        model, pdata = self.P.model, self.P.data
        lateral = np.cross(UP, direction)
        pairs, tasks = [], []
        for side, arm in self.world.robot.arms.items():
            shoulder = pdata.oMi[model.getJointId(arm.shoulder_joint)].translation
            pivot = support + float((shoulder - support) @ lateral) * lateral
            chosen = choose(landing_candidates(pivot, shoulder, direction, self.surfaces, torso_rotation,
                                               self.reach[f"{side}:{facing}"]))
            if chosen is None:
                continue
            self.landings.append(Landing(t, side, chosen))
            surface = chosen.surface
            error, J, drift = SurfacePositionTask(self.wrists[side], chosen.bip, surface.tangents).compute(model, pdata)
            tasks.append(SetPoint(self.cfg.w_landing, J, error, drift, self.cfg.task_kp, self.cfg.task_kv))
            pairs.append(SurfacePair(self.wrists[side], chosen.bip, surface.normal))
        if len(pairs) == 2:
            error, J, drift = RelativeDistanceTask(*pairs).compute(model, pdata)
            tasks.append(SetPoint(self.cfg.w_relative_distance, J, error, drift, self.cfg.task_kp, self.cfg.task_kv))
        return tasks

    def step(self, t: float, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray) -> ServoCommand:
        """One control step before impact: references integrated from the QP's accelerations."""
        assert self.direction is not None, "start() first"
        started = time.perf_counter()
        world, cfg, model = self.world, self.cfg, self.P.model
        q, v = self.P.state(qpos, qvel)
        points = environment_contacts(world.model, data, self.scenario.friction)
        terms = model_terms(self.P, q, v, points)
        torso_rotation = world.robot.torso_frame(self.P.data.oMf[model.getFrameId(world.robot.torso_body)].rotation)
        direction = self.direction.update(terms.com, torso_rotation[:, 2])
        self.classes.append(fall_class(direction, torso_rotation))
        facing = "front" if float(direction @ heading(torso_rotation)) >= 0 else "back"
        lateral_target = np.cross(UP, direction) * (1.0 if facing == "front" else -1.0)
        orientation = VectorOrientationTask(world.robot.torso_body, world.robot.torso_axis("left"), lateral_target)
        error, J, drift = orientation.compute(model, self.P.data)
        tasks = [SetPoint(cfg.w_orientation, J, error, drift, cfg.task_kp, cfg.task_kv)]
        support = np.mean([p.position for p in points], axis=0) if points else self._feet_on_ground(data)
        tasks += self._landing_tasks(t, direction, facing, torso_rotation, support)
        q_joints = q[7:][self.P.actuated_v - 6]
        tasks.append(SetPoint(cfg.w_posture, self.posture.jacobian(), self.posture.error(q_joints), self.posture.drift(),
                              cfg.task_kp, cfg.task_kv))
        problem = build_reshape_problem(self.P, terms, points, tasks, world.torque_limit, world.joint_range,
                                        self.scenario.control_dt, cfg.w_lambda, cfg.w_qdd, cfg.w_contact)
        status, solved, _, x = self.qp.solve(problem)
        qdd = x[self.P.actuated_v] if solved and np.isfinite(x).all() else np.zeros(world.model.nu)
        self.failures += not solved
        dt = self.scenario.control_dt
        self.q_ref = np.clip(self.q_ref + self.qd_ref * dt + 0.5 * qdd * dt**2, world.joint_range[:, 0], world.joint_range[:, 1])
        self.qd_ref = self.qd_ref + qdd * dt
        self.step_ms.append((time.perf_counter() - started) * 1e3)
        return ServoCommand(world.default_kp, world.default_kd, self.q_ref, self.qd_ref)

    def _feet_on_ground(self, data: mujoco.MjData) -> np.ndarray:
        """No contact at all (airborne): the feet's ground projection stands in for the pivot."""
        feet = [self.world.model.body(b).id for b in self.world.robot.body_groups["feet"]]
        below = data.xpos[feet].mean(axis=0)
        return np.array([below[0], below[1], 0.0])

    def bip_before(self, side: str, t: float) -> np.ndarray | None:
        """The BIP last chosen for this wrist at or before time t."""
        chosen = [landing.candidate.bip for landing in self.landings if landing.side == side and landing.t <= t]
        return chosen[-1] if chosen else None

    def stats(self) -> dict[str, Any]:
        if not self.step_ms:
            return {"preimpact_qp_steps": 0, "preimpact_qp_failures": 0}
        step = np.array(self.step_ms)
        return {
            "preimpact_qp_ms_median": float(np.median(step)),
            "preimpact_qp_ms_p99": float(np.percentile(step, 99)),
            "preimpact_qp_failures": self.failures,
            "preimpact_qp_steps": len(step),
            "fall_class_at_detection": self.classes[0],
            "fall_class_before_impact": self.classes[-1],
        }


RESHAPE_PARAMS = {f.name: f.default for f in dataclasses.fields(ReshapeConfig)}
