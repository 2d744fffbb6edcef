"""`adaptive_qp`: K and B decided each control step by the QP of 002 Sec. V (eqs. 10-15).

Model terms come from Pinocchio at the measured state: joint encoders, and the simulator's true
base pose and velocity (standing in for a state estimator). Contact points come from the
simulator's contact list.

Selection (eq. 15): a chain enters the selection at its body's first contact after impact and
stays in it, so a foot that loses contact for a few ms keeps its leg's adaptive gains. The motors
not selected keep their last gains (the default gains toward the impact pose): a position-
controlled robot can only realise a torque through its gains, so the QP models those motors by
their PD torque rather than giving them free torques it could not command. When the QP does not
return SOLVED the last solved gains are kept (the default gains before the first solve), and the
step is counted in `qp_failures`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from fallbench.dynamics.contacts import environment_contacts
from fallbench.dynamics.dense_qp import QP_SOLVERS, make_solver
from fallbench.dynamics.model import pinocchio_for, select_motors
from fallbench.dynamics.state import RobotState
from fallbench.postimpact.adaptive_qp.qp import QPConfig, solve_step
from fallbench.postimpact.base import GainPolicy
from fallbench.scenario import Scenario
from fallbench.sim.controllers import Observation
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World


class AdaptiveQPPolicy(GainPolicy):
    name = "adaptive_qp"
    needs_contacts = True
    defaults: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(QPConfig)}
    choices = {"solver": QP_SOLVERS}
    stat_columns: dict[str, Any] = {
        "qp_solve_ms_median": float("nan"),
        "qp_solve_ms_p99": float("nan"),
        "qp_failures": 0,
    }

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.config = QPConfig(**self.params)
        self.P = pinocchio_for(world)
        self.qp = make_solver(
            self.config.solver,
            self.config.eps_abs,
            self.config.max_iter,
            self.config.max_iter_in,
            warm_start=True,
        )
        self.com_ref: np.ndarray | None = None
        self.kp, self.kd = self.default_kp.copy(), self.default_kd.copy()
        self.selected = np.zeros(len(world.joint_names), dtype=bool)  # grows, never shrinks
        self.selecting_bodies: set[str] = set()  # bodies whose chains are in the selection
        self.records: list[dict[str, float]] = []
        self.failures = 0

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        q, v = self.P.state(observation.qpos, observation.qvel)
        if self.com_ref is None:
            self.com_ref = RobotState.measure(self.P, q, v).com
        points = environment_contacts(self.world.model, observation.data, self.scenario.friction)
        touching = set(points.bodies) - self.selecting_bodies  # the selection only grows: new bodies only
        if touching:
            self.selecting_bodies |= touching
            self.selected[select_motors(self.P, touching, self.world.joint_names)] = True
        record: dict[str, float] = {"t": observation.t, "qp_contacts": len(points)}
        if self.selected.any():
            selected = np.flatnonzero(self.selected)
            e, e_dot = q_ref - observation.q, -observation.qd
            limit = self.world.torque_limit
            held = np.clip(self.kp * e + self.kd * e_dot, -limit, limit)
            result, problem = solve_step(
                self.qp,
                self.P,
                q,
                v,
                points,
                selected,
                q_ref,
                self.com_ref,
                e,
                e_dot,
                held,
                limit,
                self.scenario.control_dt,
                self.config,
            )
            record.update(
                qp_solved=float(result.solved),
                qp_iterations=result.iterations,
                qp_model_ms=result.model_ms,
                qp_build_ms=result.build_ms,
                qp_solve_ms=result.solve_ms,
                qp_selected=len(selected),
            )
            if result.solved:
                # clip the solver's tolerance-sized excursions (~1e-3) below zero
                self.kp[selected] = np.maximum(result.K, 0.0)
                self.kd[selected] = np.maximum(result.B, 0.0)
            else:
                self.failures += 1
        self.records.append(record)
        return ServoCommand(self.kp.copy(), self.kd.copy(), q_ref, np.zeros_like(q_ref))

    def stats(self) -> dict[str, float]:
        solved = [r for r in self.records if "qp_solve_ms" in r]
        if not solved:
            return {"qp_failures": self.failures, "qp_steps": 0}
        solve = np.array([r["qp_solve_ms"] for r in solved])
        step = np.array([r["qp_model_ms"] + r["qp_build_ms"] + r["qp_solve_ms"] for r in solved])
        return {
            "qp_solve_ms_median": float(np.median(solve)),
            "qp_solve_ms_p99": float(np.percentile(solve, 99)),
            "qp_step_ms_median": float(np.median(step)),
            "qp_step_ms_p99": float(np.percentile(step, 99)),
            "qp_model_ms_median": float(np.median([r["qp_model_ms"] for r in solved])),
            "qp_build_ms_median": float(np.median([r["qp_build_ms"] for r in solved])),
            "qp_iterations_median": float(np.median([r["qp_iterations"] for r in solved])),
            "qp_failures": self.failures,
            "qp_steps": len(solved),
        }

    def failure_times(self) -> list[float]:
        return [float(r["t"]) for r in self.records if r.get("qp_solved", 1.0) == 0.0]
