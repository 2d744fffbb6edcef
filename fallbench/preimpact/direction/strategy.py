"""`direction`: direction-changing fall control among objects (Nagarajan & Goswami, 004).

Fall trigger (the episode's fall detector) -> joints held until the control trigger (steady
capture-point path, or a time limit; trigger.py) -> plan once: safe regions about the CoM,
candidates with pendulum predictions, scores and the selection rule -> every control step: eq. 5
for the swing foot, eq. 8 (partial) or eq. 6 (whole-body) inertia shaping toward the desired
direction. Joint velocities are integrated into the servo references, held by the default gains.
"""

from __future__ import annotations

import json
import math
import time
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
import pinocchio as pin

from fallbench.analysis.obstacles import actual_fall_direction_deg, direction_error_deg, fall_origin
from fallbench.analysis.safe_regions import grown_circles, object_circle, safe_regions, score
from fallbench.dynamics.model import pinocchio_for
from fallbench.dynamics.state import RobotState
from fallbench.preimpact.base import Strategy
from fallbench.preimpact.direction.candidates import Candidate, FallState, StepGrid, evaluate, step_directions
from fallbench.preimpact.direction.config import DIRECTION_PARAMS, DirectionConfig
from fallbench.preimpact.direction.inertia import (
    damped_solve,
    damped_solve_holding,
    desired_inertia,
    inertia_about,
    inertia_jacobian,
    to_vector,
)
from fallbench.preimpact.direction.oracle import oracle_subset, simulate
from fallbench.preimpact.direction.rollout import (
    REMAINDERS,
    ROLLED,
    predict_by_rollout,
    rolled_out,
    rollout_subset,
)
from fallbench.preimpact.direction.selection import (
    CAPTURE,
    MODES,
    PARTIAL_SHAPING,
    PREDICTORS,
    SELECTIONS,
    SIDES,
    WHEN_NONE_SAFE,
    WHOLE_BODY_SHAPING,
    Forced,
    Plan,
    choose,
)
from fallbench.preimpact.direction.stepping import foot_to_foot_jacobian, swing_velocity
from fallbench.preimpact.direction.support import nearest_pivot, sole_corners
from fallbench.preimpact.direction.swing import SwingPath
from fallbench.preimpact.direction.trigger import ControlTrigger
from fallbench.scenario import Scenario
from fallbench.sim.events import capture_point, support_polygon
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World

# What a rollout of a candidate changes (`snapshot`, `restore`)
ROLLOUT_STATE = (
    "plan",
    "q_ref",
    "qd_ref",
    "step_done",
    "step_error",
    "swing_path",
    "tracked",
    "tracking_switch",
)

if TYPE_CHECKING:
    from fallbench.sim.recorder import Recording


def _yaw_only(rotation: np.ndarray) -> np.ndarray:
    yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    return pin.utils.rpyToMatrix(0.0, 0.0, yaw)


class DirectionStrategy(Strategy):
    name = "direction"
    defaults = DIRECTION_PARAMS
    robot_needs = ("feet",)  # the soles it steps and lifts
    choices = {
        "mode": MODES,
        "selection": SELECTIONS,
        "swing_side": SIDES,
        "predictor": PREDICTORS,
        "partial_shaping": PARTIAL_SHAPING,
        "whole_body_shaping": WHOLE_BODY_SHAPING,
        "capture": CAPTURE,
        "when_none_safe": WHEN_NONE_SAFE,
        "rollout_remainder": REMAINDERS,
        "rollout_candidates": ROLLED,
    }

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.config = config = DirectionConfig(**self.params)
        self.P = pinocchio_for(world)
        model = self.P.model
        self.feet = world.robot.feet
        self.frames = {side: model.getFrameId(body) for side, body in self.feet.items()}
        self.foot_sensors = {side: self._foot_sensor_columns(world, body) for side, body in self.feet.items()}
        self.chains = {
            side: set(model.supports[model.frames[f].parentJoint]) for side, f in self.frames.items()
        }
        self.leg_columns = {
            side: np.array(sorted(model.joints[j].idx_v - 6 for j in chain if j > 1))
            for side, chain in self.chains.items()
        }
        every = np.arange(model.nv - 6)
        self.upper_columns = np.setdiff1d(every, np.concatenate(list(self.leg_columns.values())))
        self.speed_limit = model.velocityLimit[6:]
        self.objects = [object_circle(o) for o in scenario.obstacles]
        self.grid = StepGrid(
            np.arange(config.step_radius_min, config.step_radius_max + 1e-9, config.step_radius_step),
            np.radians(np.arange(0.0, 360.0, config.step_heading_step)),
            config.step_time_offset,
            config.step_time_per_m,
            config.min_foot_separation,
            2 * config.robot_radius,
        )
        self.trigger = ControlTrigger(
            config.trigger_window, config.trigger_tolerance, config.trigger_min_travel, config.trigger_timeout
        )
        self.plan: Plan | None = None
        self.plan_ms = math.nan
        self.origin = np.zeros(2)
        self.regions: list = []
        self.com_height = math.nan
        self.standing: dict[str, pin.SE3] = {}  # foot frames at the fall trigger, soles flat
        self.sole_centres: dict[str, np.ndarray] = {}  # m, (2,) at the control trigger
        self.step_done: float | None = None  # s, when the step's foot touched down
        self.step_error = math.nan  # m, its sole centre from the target then
        self.swing_path: SwingPath | None = None  # Take a Step's, from the first control step
        self.tracked: float | None = None  # s, last tracking prediction
        self.tracking_switch = math.nan  # s, when tracking started whole-body inertia shaping
        self.q_ref = self.qd_ref = np.zeros(world.model.nu)
        self.step_ms: list[float] = []

    # ------------------------------------------------------------------ episode hooks

    def start(self, t: float, data: mujoco.MjData) -> None:
        state = RobotState.measure(self.P, *self.P.state(data.qpos, data.qvel))
        self.com_height = float(state.com[2])
        self.standing = {side: state.frame_placement(f).copy() for side, f in self.frames.items()}
        self.q_ref = (
            data.ctrl.copy()
        )  # the references held so far: the joints stay locked until the control trigger
        self.qd_ref = np.zeros_like(self.q_ref)

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        started = time.perf_counter()
        state = RobotState.measure(self.P, *self.P.state(data.qpos, data.qvel))
        com, com_velocity = state.com, state.com_velocity
        xi = capture_point(com, com_velocity)
        if self.plan is None:
            if not self.trigger.update(t, xi):
                return None
            self._plan(t, data, com, com_velocity)
        self._track(t, data, com, com_velocity)
        command = self._control(t, data, state, xi)
        self.step_ms.append((time.perf_counter() - started) * 1e3)
        return command

    def planned_contacts(self) -> set[str]:
        if self.plan is None or self.plan.chosen.swing is None:
            return set()
        body = self.world.model.body(self.feet[self.plan.chosen.swing])
        return {body.name, self.world.model.body(body.parentid[0]).name}

    # ------------------------------------------------------------------ planning

    def _plan(self, t: float, data: mujoco.MjData, com: np.ndarray, com_velocity: np.ndarray) -> None:
        started = time.perf_counter()
        config = self.config
        self.origin = com[:2].copy()
        circles = grown_circles(
            self.scenario.obstacles,
            self.origin,
            config.robot_radius,
            config.consider_factor * config.robot_height,
        )
        self.regions = safe_regions(circles, self.origin, math.radians(config.cone_margin))
        soles = {side: sole_corners(self.world.model, data, body) for side, body in self.feet.items()}
        self.sole_centres = {side: corners.mean(axis=0) for side, corners in soles.items()}
        state = FallState(com, com_velocity, 0.0, config.touchdown_fraction * self.com_height)
        candidates, _ = evaluate(soles, state, self.grid, self.objects)
        if config.predictor == "oracle":  # each candidate simulated: perfect, not real-time prediction
            candidates = oracle_subset(candidates)
            for candidate in candidates:
                candidate.direction, candidate.capturing = simulate(self, data, t, candidate)
        elif config.predictor == "rollout":  # the steps (and lifts) simulated briefly: not real time
            candidates = rollout_subset(candidates, config)
            for candidate in candidates:
                if rolled_out(candidate, config.rollout_candidates):
                    rolled = predict_by_rollout(self, data, t, candidate)
                    candidate.direction, candidate.capturing = rolled.direction, rolled.capturing
                    candidate.capture_margin = rolled.capture_margin  # `capture: prefer` ranks steps by it
        self.plan = choose(
            candidates,
            self.regions,
            config.mode,
            config.selection,
            config.w1,
            config.w2,
            config.allow_capture,
            Forced(config.swing_side, config.step_length, config.step_bearing),
            config.capture,
            config.when_none_safe,
        )
        shaping = self.plan.inertia_shaping
        if (
            config.predictor == "oracle"  # run the chosen candidate as it was simulated: no shaping
            or (shaping == "pis" and config.partial_shaping == "off")
            or (shaping == "wbis" and config.mode == "auto" and config.whole_body_shaping == "off")
        ):
            self.plan.inertia_shaping = ""
        self.plan_ms = (time.perf_counter() - started) * 1e3

    # ------------------------------------------------------------------ control

    @staticmethod
    def _foot_sensor_columns(world: World, foot: str) -> np.ndarray:
        """sensordata columns of the "found" counts of a foot's contact sensors (the foot body's and its
        parent's, whichever carries the sole)."""
        body = world.model.body(foot)
        names = (f"contact:feet:{body.name}", f"contact:feet:{world.model.body(body.parentid[0]).name}")
        return np.array([world.sensors[name].start for name in names if name in world.sensors], dtype=int)

    def _touching(self, data: mujoco.MjData, side: str) -> bool:
        """Whether a foot's contact sensors see the ground (or an object)."""
        return bool((data.sensordata[self.foot_sensors[side]] > 0).any())

    def _swing(self, t: float, data: mujoco.MjData, state: RobotState, qdot: np.ndarray) -> None:
        """Eq. 5 toward the lifted pose (Lift a Leg) or along the step's swing path (Take a Step)."""
        assert self.plan is not None
        chosen, config = self.plan.chosen, self.config
        swing = chosen.swing
        assert swing is not None
        stance = next(s for s in self.frames if s != swing)
        frame, home = self.frames[swing], self.standing[swing]
        position = state.frame_placement(frame).translation
        if chosen.kind == "lift_leg":
            target = home.translation + np.array([0.0, 0.0, config.lift_height])
        else:
            assert chosen.target is not None
            if (
                self.swing_path is None
            ):  # the sole centre moves to the target: the frame moves by the same horizontal offset
                self.swing_path = SwingPath(
                    home.translation.copy(),
                    home.translation[:2] + chosen.target - self.sole_centres[swing],
                    config.lift_height,
                    0.5 * config.step_tolerance,
                )
            if self.swing_path.landed(position, self._touching(data, swing)):
                self.step_done = t
                self.step_error = float(np.linalg.norm(position[:2] - self.swing_path.target_xy))
                return
            target = self.swing_path.waypoint(position)
        columns = self.leg_columns[swing]
        qdot[columns] = swing_velocity(
            state,
            frame,
            self.frames[stance],
            columns + 6,
            target,
            _yaw_only(home.rotation),
            config.step_gain,
            config.foot_speed,
            config.damping,
        )

    def _supporting(self) -> list[str]:
        """The feet on the ground as planned: both, or the stance foot while the other is lifted or
        on its way (a landed step supports again)."""
        assert self.plan is not None
        swing = self.plan.chosen.swing
        return [
            side
            for side in self.feet
            if side != swing or (self.plan.chosen.kind == "take_step" and self.step_done is not None)
        ]

    def _track(self, t: float, data: mujoco.MjData, com: np.ndarray, com_velocity: np.ndarray) -> None:
        """004 Secs. IV, VI: the strategy runs "in an interactive manner": every `tracking_period` s
        the fall is predicted again from the present state about the present support, and whole-body
        inertia shaping starts when it has become unsafe; a step is tracked only once its foot is
        down. Forced modes (ablations) run as chosen."""
        plan, config = self.plan, self.config
        assert plan is not None
        if (
            not config.tracking
            or config.mode != "auto"
            or plan.chosen.kind == "no_action"
            or plan.inertia_shaping == "wbis"
            or config.predictor == "oracle"
            or config.whole_body_shaping == "off"
        ):
            return
        if plan.chosen.kind == "take_step" and self.step_done is None:
            return  # 004 Sec. I-c: whole-body inertia shaping "cannot be launched before foot placement is completed"
        if self.tracked is not None and t - self.tracked < config.tracking_period - 1e-9:
            return
        self.tracked = t
        state = FallState(com, com_velocity, 0.0, config.touchdown_fraction * self.com_height)
        polygon = plan.chosen.polygon
        if plan.chosen.kind == "take_step":  # landed: about the present support
            polygon = support_polygon(
                np.vstack([sole_corners(self.world.model, data, body) for body in self.feet.values()])
            )
        directions, _, _ = step_directions([polygon], com[None], com_velocity[None], self.origin, state)
        if score(float(directions[0]), self.regions, config.w1, config.w2) > 1.0:
            plan.inertia_shaping, self.tracking_switch = "wbis", t

    def _shape(self, data: mujoco.MjData, state: RobotState, xi: np.ndarray, qdot: np.ndarray) -> None:
        """Eq. 8 (partial: joints free of the foot placement) or eq. 6 (whole body), about the CoP.
        J_I holds the stance foot on the ground; with both soles down the shaping also keeps the other
        one where it is (zero foot-to-foot twist, eq. 5's Jacobian): a grounded foot cannot follow a
        swing of its leg, which would instead move, and fold, the body."""
        assert self.plan is not None and self.plan.desired is not None
        model, pdata, plan = self.P.model, self.P.data, self.plan
        supporting = self._supporting()
        swing = next((side for side in self.feet if side not in supporting), None)
        soles = [sole_corners(self.world.model, data, self.feet[side]) for side in supporting]
        pivot = nearest_pivot(support_polygon(np.vstack(soles)), xi)
        point = np.array([*pivot.point, 0.0])
        stance = (
            next((s for s in self.frames if s != swing), "left")
            if swing
            else min(
                self.frames,
                key=lambda s: float(
                    np.linalg.norm(state.frame_placement(self.frames[s]).translation[:2] - pivot.point)
                ),
            )
        )
        # ccrba at the state's (q, v): the state's Jacobians and frame placements stay as they were
        inertia, momentum = inertia_about(model, pdata, state.q, state.v, point)
        jacobian = inertia_jacobian(model, pdata, point, self.chains[stance])
        error = to_vector(desired_inertia(inertia, momentum, plan.desired)) - to_vector(inertia)
        if plan.inertia_shaping == "wbis":
            columns, placement = np.arange(model.nv - 6), np.array([], dtype=int)
        else:
            placement = self.leg_columns[plan.chosen.swing]
            columns = (
                self.upper_columns
                if plan.chosen.kind == "take_step" or self.config.partial_shaping == "upper_body"
                else np.setdiff1d(np.arange(model.nv - 6), placement)
            )
        rhs = self.config.inertia_gain * error - jacobian[:, placement] @ qdot[placement]
        if swing is None:
            held = foot_to_foot_jacobian(state, self.frames["right"], self.frames["left"], columns + 6)
            qdot[columns] = damped_solve_holding(jacobian[:, columns], rhs, held, self.config.damping)
        else:
            qdot[columns] = damped_solve(jacobian[:, columns], rhs, self.config.damping)

    def _control(self, t: float, data: mujoco.MjData, state: RobotState, xi: np.ndarray) -> ServoCommand:
        assert self.plan is not None
        qdot = np.zeros(self.P.model.nv - 6)
        if self.plan.chosen.swing is not None and self.step_done is None:
            self._swing(t, data, state, qdot)
            self._within_speed_limits(qdot)
        if self.plan.inertia_shaping and self.plan.desired is not None:
            placed = qdot.copy()
            self._shape(data, state, xi, qdot)
            shaping = qdot - placed
            self._within_speed_limits(
                shaping
            )  # the foot placement keeps its speed, inertia shaping gets scaled
            qdot = placed + shaping
        world, dt = self.world, self.scenario.control_dt
        self.qd_ref = qdot[self.P.actuated_v - 6]
        self.q_ref = np.clip(self.q_ref + self.qd_ref * dt, world.joint_range[:, 0], world.joint_range[:, 1])
        return ServoCommand(world.default_kp, world.default_kd, self.q_ref, self.qd_ref)

    def _within_speed_limits(self, qdot: np.ndarray) -> None:
        """Scale joint velocities (in place) to the joints' rated speeds, keeping their direction."""
        excess = float(np.max(np.abs(qdot) / self.speed_limit))
        if excess > 1.0:
            qdot /= excess

    # ------------------------------------------------------------------ simulated ahead (oracle.py, rollout.py)

    def snapshot(self) -> dict[str, Any]:
        """The state a rollout of a candidate changes (its plan, references, step and tracking), for
        `restore` to put back: the objects themselves, which a rollout replaces but never changes."""
        return {name: getattr(self, name) for name in ROLLOUT_STATE}

    def restore(self, snapshot: dict[str, Any]) -> None:
        for name, value in snapshot.items():
            setattr(self, name, value)

    def rehearse(self, candidate: Candidate) -> None:
        """Ready to simulate `candidate` alone (no inertia shaping): its plan, no step taken, no swing
        path, no tracking yet, and copies of the present references."""
        self.plan = Plan(candidate, "", None, [])
        self.step_done, self.swing_path, self.tracked = None, None, None
        self.q_ref, self.qd_ref = self.q_ref.copy(), self.qd_ref.copy()

    # ------------------------------------------------------------------ results

    def stats(self) -> dict[str, Any]:
        return {"direction_step_ms_median": float(np.median(self.step_ms)) if self.step_ms else math.nan}

    def metrics(self, recording: Recording) -> dict[str, Any]:
        plan = self.plan
        row: dict[str, Any] = {
            "direction_strategy": plan.label if plan else "",
            "control_trigger_time": self.trigger.time if self.trigger.time is not None else math.nan,
            "control_trigger_reason": self.trigger.reason,
            "direction_plan_ms": self.plan_ms,
            "direction_tracking_switch_time": self.tracking_switch,
            "predicted_fall_direction_deg": math.degrees(plan.chosen.direction) if plan else math.nan,
            "predicted_score": plan.chosen.score if plan else math.nan,
            "desired_fall_direction_deg": math.degrees(plan.desired)
            if plan and plan.desired is not None
            else math.nan,
            "direction_origin_x": float(self.origin[0]) if plan else math.nan,
            "direction_origin_y": float(self.origin[1]) if plan else math.nan,
        }
        if recording.scenario.obstacles:  # the prediction against the outcome among objects
            actual = actual_fall_direction_deg(recording, fall_origin(row, recording))
            row["fall_direction_error_deg"] = direction_error_deg(row["predicted_fall_direction_deg"], actual)
        impacts = [e.t for e in recording.impact_events]
        if plan and plan.chosen.kind == "take_step":
            row["step_completed"] = (
                self.step_done is not None
                and (not impacts or self.step_done <= impacts[0])
                and self.step_error <= self.config.step_tolerance
            )
            row["step_error"] = self.step_error
            row["step_landed_time"] = (  # s after the control trigger
                self.step_done - self.trigger.time
                if self.step_done is not None and self.trigger.time is not None
                else math.nan
            )
            row["step_length"] = (
                float(np.linalg.norm(plan.chosen.step)) if plan.chosen.step is not None else math.nan
            )
            assert plan.chosen.target is not None
            row["step_target_x"], row["step_target_y"] = (float(x) for x in plan.chosen.target)
        if plan:
            best = {}
            usable = [
                c
                for c in plan.candidates
                if c.kind == "no_action" or self.config.allow_capture or not c.capturing
            ]
            for c in sorted(usable, key=lambda c: c.score):
                best.setdefault(c.name, c)
            row["direction_candidates"] = json.dumps(
                [
                    {
                        "name": c.name,
                        "deg": round(math.degrees(c.direction), 1),
                        "score": round(c.score, 3) if math.isfinite(c.score) else None,
                        "capturing": c.capturing,
                    }
                    for c in best.values()
                ]
            )
        return row
