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
from typing import Any, Literal

import mujoco
import numpy as np

from fallbench.dynamics.contacts import ContactSet, environment_contacts
from fallbench.dynamics.dense_qp import make_solver
from fallbench.dynamics.fall_direction import FallDirection, fall_class, heading
from fallbench.dynamics.limits.joint import bounded_reference, inner_range, servo_lag
from fallbench.dynamics.model import pinocchio_for
from fallbench.dynamics.objective import SetPoint
from fallbench.dynamics.state import RobotState
from fallbench.dynamics.tasks.body_point import BodyPoint
from fallbench.dynamics.tasks.point import PointTask
from fallbench.dynamics.tasks.posture import PostureTask
from fallbench.dynamics.tasks.relative_distance import RelativeDistanceTask, SurfacePair
from fallbench.dynamics.tasks.surface_position import SurfacePositionTask
from fallbench.dynamics.tasks.task import TaskTerms
from fallbench.dynamics.tasks.vector_orientation import VectorOrientationTask
from fallbench.dynamics.terms import model_terms
from fallbench.dynamics.vectors import UP, cross
from fallbench.preimpact.reshape.fall_posture import fall_posture
from fallbench.preimpact.reshape.landing import Candidate, choose, landing_candidates
from fallbench.preimpact.reshape.qp import build_reshape_problem, solve_reshape
from fallbench.preimpact.reshape.reach import reach_polyhedra
from fallbench.preimpact.reshape.surfaces import scene_surfaces
from fallbench.scenario import Scenario
from fallbench.sim.servo import ServoCommand
from fallbench.sim.support import body_box_corners, world_corners
from fallbench.sim.world import World

PIVOTS = ("contacts", "knees", "knees_and_buttocks")


@dataclass(frozen=True)
class ReshapeConfig:
    """Task weights and gains of the reshaping QP (documented in docs/methods/reshape.md)."""

    w_orientation: float = 10.0
    w_landing: float = 10.0  # each wrist toward its BIP, along the surface
    w_relative_distance: float = 10.0
    w_posture: float = 1.0
    # The posture task's rows of the leg joints: a symmetric crouch, both knees together. At 100 the
    # legs hold their target against the arm and torso tasks' reaction through the floating base
    # (front falls on scenarios/reshape_dev.yaml: both knees or the hands first in 18/22 falls,
    # 13/22 at 10).
    w_leg_posture: float = 100.0
    # The torso-orientation and wrist-landing tasks move the torso and arms only: the legs follow
    # the posture task alone, symmetric, so that both knees land together (000 Sec. IV-B: the two
    # feet, then the two knees at the same moment; 002 eq. 1's selection matrix S_M).
    landing_uses_legs: bool = False
    task_kp: float = 40.0  # 1/s^2, every task
    task_kv: float = 12.6  # 1/s, critically damped for task_kp
    knee_bend: float = 1.6  # rad, knee target of the fall posture (back falls; front with crouch_front)
    # Front falls: the legs keep the starting posture unless this is set. A crouch brings the knees
    # down before the hands, and the crouched robot rolls onto one knee: measured on
    # scenarios/reshape_dev.yaml, one knee landed alone in 15 of 22 front falls with the 1.6 rad
    # crouch (docs/methods/reshape.md).
    crouch_front: bool = False
    # Back falls: the elbow target as a fraction of the angle of highest manipulability (000
    # Sec. IV-C: "not too small"); a straighter arm reaches below the buttocks in time.
    elbow_back: float = 0.5
    # Side falls (class at detection left/right): a deeper crouch lowers the hip before it lands.
    knee_bend_side: float = 2.1  # rad
    # Front falls: both knees at the same height, with the legs (hips), so that they land together
    # (000 Sec. IV-B: "the two knees at the same moment ... hip joints are used").
    w_knees_level: float = 100.0
    # Back falls: each wrist toward the height of the buttocks' lowest point minus this offset, so
    # that the hands land before the buttocks (000 Sec. IV-C, eq. 2's P_b offset along the normal).
    w_hands_below_butt: float = 50.0
    hands_below_butt: float = 0.2  # m
    # m the capture point must be outside the feet's support polygon before reshaping starts
    # (or the torso tilt past `detection.tilt`): at the declaring 0.02 m the capture point fired on
    # 10 of the 22 pushes and drops G1 survives in scenarios/detection_dev.yaml, at 0.1 m on none,
    # and reshape, which commits at once, made G1 fall from pushes it survives (docs/detection.md).
    start_margin: float = 0.1
    w_lambda: float = 1e-6
    w_qdd: float = 1e-4
    w_contact: float = 100.0  # contact points neither sinking in nor lifting off (a cost, not a constraint)
    # Off by default (docs/methods/reshape.md, "Joint-limit margin"): the QP keeps every joint this far
    # inside its range, and the servo reference too; a joint already in the margin may stay there.
    joint_limit_margin: float = 0.0  # rad
    # The servo reference's velocity is cut so that the PD's rest point q_ref + (B / K) qd_ref stays
    # inside the range less the margin: a reference held on a range end carries no velocity past it.
    joint_limit_servo_lag: bool = False
    # Off by default: the QP holds each joint's speed toward a range end to what this fraction of
    # its motor's torque limit, over the joint's own inertia, can stop before the end (a viability
    # bound; the 20 ms horizon alone lets a fast joint arrive faster than its motor can brake).
    joint_limit_braking: float = 0.0  # fraction of torque limit / H_kk
    # 000 Sec. IV-A pulls the hands up so that the wrists land first; how far is open: the wrist
    # pitch's target as a fraction of its range toward the hand-up end
    wrist_bend: float = 0.8
    # Off by default (anti-windup): the servo reference's lead on its joint bounded to this many
    # torque limit / kp (rad), the lead at which the servo saturates anyway; 0: unbounded, the
    # reference integrated from the QP's accelerations alone
    reference_lead: float = 0.0
    pivot: Literal["contacts", "knees", "knees_and_buttocks"] = (
        "contacts"  # the landing search's stick, see _stick
    )
    solver: str = "proxsuite"  # or "daqp" (fallbench.dynamics.dense_qp.QP_SOLVERS)
    eps_abs: float = 1e-6  # ProxSuite's absolute tolerance, DAQP's primal tolerance
    # ProxSuite's iteration caps bound its rare very long solves (seen: 49 s with ProxSuite's
    # defaults); a capped solve counts as a failure and the references coast for that step.
    max_iter: int = 200
    max_iter_in: int = 100

    def __post_init__(self) -> None:
        if self.pivot not in PIVOTS:
            raise ValueError(f"reshape: pivot must be one of {', '.join(PIVOTS)}, not {self.pivot!r}")
        if not 0.0 <= self.elbow_back <= 1.0:
            raise ValueError(f"reshape: elbow_back must be in [0, 1], not {self.elbow_back}")
        if self.joint_limit_margin < 0.0:
            raise ValueError(f"reshape: joint_limit_margin must be >= 0, not {self.joint_limit_margin}")
        if self.joint_limit_braking < 0.0:
            raise ValueError(f"reshape: joint_limit_braking must be >= 0, not {self.joint_limit_braking}")
        if not 0.0 <= self.wrist_bend <= 1.0:
            raise ValueError(f"reshape: wrist_bend must be in [0, 1], not {self.wrist_bend}")
        if self.reference_lead < 0.0:
            raise ValueError(f"reshape: reference_lead must be >= 0, not {self.reference_lead}")


@dataclass
class Landing:
    t: float
    side: str
    candidate: Candidate


class ReshapeController:
    """The reshaping controller of one episode: `start` at fall detection, then `step` per control step."""

    def __init__(self, world: World, scenario: Scenario, params: dict[str, Any] | None = None) -> None:
        self.world, self.scenario = world, scenario
        self.config = ReshapeConfig(**(params or {}))
        self.P = pinocchio_for(world)
        robot = world.robot
        self.reach = reach_polyhedra(robot, self.P.model)
        self.surfaces = scene_surfaces(scenario)
        start = {**robot.postures[scenario.initial.posture], **scenario.initial.joints}
        start = {j: start.get(j, 0.0) for j in world.joint_names}
        self.postures = {}  # "front", "back" and "side" fall postures
        front_bend = self.config.knee_bend if self.config.crouch_front else None
        for kind, bend, elbow in (
            ("front", front_bend, 1.0),
            ("back", self.config.knee_bend, self.config.elbow_back),
            ("side", self.config.knee_bend_side, 1.0),
        ):
            target = fall_posture(self.P.model, robot, start, bend, elbow, self.config.wrist_bend)
            self.postures[kind] = PostureTask(
                np.array([target[j] for j in world.joint_names]), self.P.actuated_v, self.P.model.nv
            )
        self.wrists = {side: BodyPoint(arm.wrist_frame, np.zeros(3)) for side, arm in robot.arms.items()}
        self.knees = [
            BodyPoint(world.model.body(world.model.jnt_bodyid[world.model.joint(j).id]).name, np.zeros(3))
            for j in robot.knee_joints
        ]
        self.seat = [body_box_corners(world.model, body) for body in seat_bodies(world)]
        leg_joints = [
            j
            for root in (leg[0] for leg in robot.legs.values())
            for j in self.P.model.subtrees[self.P.model.getJointId(root)]
        ]
        self.leg_v = np.array([self.P.model.joints[j].idx_v for j in leg_joints], dtype=int)
        self.legs = np.isin(self.P.actuated_v, self.leg_v)  # actuators of the legs
        self.band = inner_range(world.joint_range, self.config.joint_limit_margin)  # rad
        lag = servo_lag(world.default_kp, world.default_kd)  # s
        self.lag = lag if self.config.joint_limit_servo_lag else np.zeros(world.model.nu)
        # rad: the servo reference's largest lead on its joint (`reference_lead`); inf where kp is 0
        saturating = np.divide(
            world.torque_limit,
            world.default_kp,
            out=np.full(world.model.nu, np.inf),
            where=world.default_kp > 0,
        )
        self.lead = self.config.reference_lead * saturating if self.config.reference_lead else None
        self.qp = make_solver(
            self.config.solver, self.config.eps_abs, self.config.max_iter, self.config.max_iter_in
        )
        self.direction: FallDirection | None = None
        self.q_ref = self.qd_ref = np.zeros(world.model.nu)
        self.landings: list[Landing] = []
        self.classes: list[str] = []
        self.step_ms: list[float] = []  # whole steps
        self.solve_ms: list[float] = []  # the solver's part of each
        self.failures = 0

    def start(self, qpos: np.ndarray, qvel: np.ndarray, q: np.ndarray, qd: np.ndarray) -> None:
        """At fall detection: references from the measured joints, CoM for the fall direction."""
        pq, pv = self.P.state(qpos, qvel)
        self.direction = FallDirection(RobotState.measure(self.P, pq, pv).com)
        self.q_ref, self.qd_ref = q.copy(), qd.copy()

    def _landing_tasks(
        self,
        t: float,
        state: RobotState,
        direction: np.ndarray,
        facing: str,
        torso_rotation: np.ndarray,
        stick: tuple[np.ndarray, float],
    ) -> list[SetPoint]:
        lateral = cross(UP, direction)
        support, drop = stick
        pairs, tasks = [], []
        for side, arm in self.world.robot.arms.items():
            shoulder = state.data.oMi[state.model.getJointId(arm.shoulder_joint)].translation - drop * UP
            pivot = support + float((shoulder - support) @ lateral) * lateral
            chosen = choose(
                landing_candidates(
                    pivot, shoulder, direction, self.surfaces, torso_rotation, self.reach[f"{side}:{facing}"]
                )
            )
            if chosen is None:
                continue
            self.landings.append(Landing(t, side, chosen))
            surface = chosen.surface
            landing = SurfacePositionTask(self.wrists[side], chosen.bip, surface.tangents).compute(state)
            tasks.append(self._set_point(self.config.w_landing, self._select(landing)))
            pairs.append(SurfacePair(self.wrists[side], chosen.bip, surface.normal))
        if len(pairs) == 2:
            synchronised = RelativeDistanceTask(*pairs).compute(state)
            tasks.append(self._set_point(self.config.w_relative_distance, self._select(synchronised)))
        return tasks

    def step(self, t: float, data: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray) -> ServoCommand:
        """One control step before impact: references integrated from the QP's accelerations."""
        started = time.perf_counter()
        world, config = self.world, self.config
        q, v = self.P.state(qpos, qvel)
        points = environment_contacts(world.model, data, self.scenario.friction)
        terms = model_terms(self.P, q, v, points, inertia=True, inverse=False)
        tasks = self._tasks(t, data, terms.state, points)
        problem = build_reshape_problem(
            terms,
            tasks,
            world.torque_limit,
            world.joint_range,
            self.scenario.control_dt,
            config.w_lambda,
            config.w_qdd,
            config.w_contact,
            config.joint_limit_margin,
            config.joint_limit_braking,
        )
        solving = time.perf_counter()
        status, solved, accelerations = solve_reshape(self.qp, problem)
        self.solve_ms.append((time.perf_counter() - solving) * 1e3)
        qdd = accelerations[self.P.actuated_v] if accelerations is not None else np.zeros(world.model.nu)
        self.failures += not solved
        dt = self.scenario.control_dt
        q_ref = self.q_ref + self.qd_ref * dt + 0.5 * qdd * dt**2
        if self.lead is not None:
            # anti-windup: beyond torque limit / kp from the joint the servo saturates anyway, and a
            # reference integrated further ahead only swings the joint past it once it catches up
            measured = qpos[world.qpos_adr]
            q_ref = np.clip(q_ref, measured - self.lead, measured + self.lead)
        self.q_ref, self.qd_ref = bounded_reference(q_ref, self.qd_ref + qdd * dt, self.band, self.lag)
        self.step_ms.append((time.perf_counter() - started) * 1e3)
        return ServoCommand(world.default_kp, world.default_kd, self.q_ref, self.qd_ref)

    def _tasks(self, t: float, data: mujoco.MjData, state: RobotState, points: ContactSet) -> list[SetPoint]:
        """The reshaping tasks of this step (see the module's docstring)."""
        assert self.direction is not None, "start() first"
        world, config = self.world, self.config
        torso_rotation = world.robot.torso_frame(
            state.frame_placement(self.P.frame_id(world.robot.torso_body)).rotation
        )
        direction = self.direction.update(state.com, torso_rotation[:, 2])
        self.classes.append(fall_class(direction, torso_rotation))
        facing = "front" if float(direction @ heading(torso_rotation)) >= 0 else "back"
        lateral_target = cross(UP, direction) * (1.0 if facing == "front" else -1.0)
        orientation = VectorOrientationTask(
            world.robot.torso_body, world.robot.torso_axis("left"), lateral_target
        )
        tasks = [self._set_point(config.w_orientation, orientation.compute(state))]
        support = points.positions.mean(axis=0) if len(points) else self._feet_on_ground(data)
        tasks += self._landing_tasks(
            t, state, direction, facing, torso_rotation, self._stick(data, state, support, direction)
        )
        if facing == "back":
            tasks += self._hands_below_butt(data, state)
        elif len(self.knees) == 2:
            floor = [SurfacePair(knee, np.zeros(3), UP) for knee in self.knees]
            tasks.append(self._set_point(config.w_knees_level, RelativeDistanceTask(*floor).compute(state)))
        kind = "side" if self.classes[0] in ("left", "right") else facing
        posture = self.postures[kind].compute(state)
        for rows, weight in ((~self.legs, config.w_posture), (self.legs, config.w_leg_posture)):
            tasks.append(self._set_point(weight, posture.select(rows)))
        return tasks

    def _set_point(self, weight: float, terms: TaskTerms) -> SetPoint:
        """A task in the cost, at the gains every reshaping task shares."""
        return SetPoint(weight, terms, self.config.task_kp, self.config.task_kv)

    def _stick(
        self, data: mujoco.MjData, state: RobotState, support: np.ndarray, direction: np.ndarray
    ) -> tuple[np.ndarray, float]:
        """The stick's ground pivot (002 Sec. IV-B) and the height (m) the robot drops onto it.

        `contacts`: the mean of the contact points, no drop, as in 002. `knees`: the point farthest
        along the fall direction among that one and the knees: a robot that crouches while it falls
        forward drops onto its knees and then turns about them, so the stick stands on the knee's
        ground projection with the knee-to-shoulder length (the shoulders are lowered by the knee's
        height). `knees_and_buttocks` adds the buttocks' lowest corner, for back falls."""
        if self.config.pivot == "contacts":
            return support, 0.0
        candidates = [knee.position(state) for knee in self.knees]
        if self.config.pivot == "knees_and_buttocks":
            candidates.append(self._butt_point(data))
        lead = max(candidates, key=lambda point: float(point @ direction))
        if float(lead @ direction) <= float(support @ direction):
            return support, 0.0
        return np.array([lead[0], lead[1], support[2]]), max(float(lead[2] - support[2]), 0.0)

    def _butt_point(self, data: mujoco.MjData) -> np.ndarray:
        """Lowest corner (m, world) of the seat's collision geometry (`seat_bodies`: the root body
        and the legs above the knees), 000 Sec. IV-C's P_b."""
        corners = np.concatenate([world_corners(data, geoms, box) for geoms, box in self.seat if len(geoms)])
        return corners[np.argmin(corners[:, 2])]

    def _hands_below_butt(self, data: mujoco.MjData, state: RobotState) -> list[SetPoint]:
        """000 Sec. IV-C: the wrists below the buttocks by `hands_below_butt`, along the vertical."""
        target = np.array([0.0, 0.0, float(self._butt_point(data)[2]) - self.config.hands_below_butt])
        return [
            self._set_point(
                self.config.w_hands_below_butt,
                self._select(PointTask(wrist, target, slice(2, 3)).compute(state)),
            )
            for wrist in self.wrists.values()
        ]

    def _select(self, terms: TaskTerms) -> TaskTerms:
        """A task's terms without the leg columns of its Jacobian unless `landing_uses_legs`."""
        if self.config.landing_uses_legs:
            return terms
        jacobian = terms.jacobian.copy()
        jacobian[:, self.leg_v] = 0.0
        return dataclasses.replace(terms, jacobian=jacobian)

    def _feet_on_ground(self, data: mujoco.MjData) -> np.ndarray:
        """No contact at all (airborne): the feet's ground projection stands in for the pivot."""
        feet = [self.world.model.body(b).id for b in self.world.robot.body_groups["feet"]]
        below = data.xpos[feet].mean(axis=0)
        return np.array([below[0], below[1], 0.0])

    def bip_before(self, side: str, t: float) -> np.ndarray | None:
        """The BIP last chosen for this wrist at or before time t."""
        chosen = [
            landing.candidate.bip for landing in self.landings if landing.side == side and landing.t <= t
        ]
        return chosen[-1] if chosen else None

    def stats(self) -> dict[str, Any]:
        if not self.step_ms:
            return {"preimpact_qp_steps": 0, "preimpact_qp_failures": 0}
        step = np.array(self.step_ms)
        return {
            "preimpact_qp_ms_median": float(np.median(step)),
            "preimpact_qp_ms_p99": float(np.percentile(step, 99)),
            "preimpact_qp_solve_ms_median": float(np.median(self.solve_ms)),
            "preimpact_qp_solve_ms_p99": float(np.percentile(self.solve_ms, 99)),
            "preimpact_qp_failures": self.failures,
            "preimpact_qp_steps": len(step),
            "fall_class_at_detection": self.classes[0],
            "fall_class_before_impact": self.classes[-1],
        }


def seat_bodies(world: World) -> list[int]:
    """MuJoCo ids of the bodies a robot sits on in a back fall: the root body and every body between
    it and a knee (hips and thighs). In a crouched back fall TALOS lands on a thigh and a hip
    first and on its root body 0.3 s later or not at all (scenarios/reshape_dev.yaml), so the
    buttocks' point P_b of 000 Sec. IV-C is the lowest point of these bodies, not of the root
    body alone."""
    model = world.model
    bodies = {world.root_body}
    for joint in world.robot.knee_joints:
        body = model.body_parentid[model.jnt_bodyid[model.joint(joint).id]]
        while body > 0 and body != world.root_body:
            bodies.add(int(body))
            body = model.body_parentid[body]
    return sorted(bodies)


RESHAPE_PARAMS = {f.name: f.default for f in dataclasses.fields(ReshapeConfig)}
