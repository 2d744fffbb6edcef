"""`adaptive_qp`: K and B decided each control step by the QP of 002 Sec. V (eqs. 10-15).

Model terms come from Pinocchio at the measured state: joint encoders, and the simulator's true
base pose and velocity (standing in for a state estimator). Contact points come from the
simulator's contact list. Motors on the chains from the contact bodies to the root get the QP's
gains; the other motors keep theirs. When the QP does not return SOLVED, the last solved gains
are kept (the default gains before the first solve), and the step is counted in `qp_failures`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from fallbench.control.adaptive_gains_qp import QPConfig, solve_step
from fallbench.dynamics.dense_qp import DenseQP
from fallbench.dynamics.contacts import environment_contacts
from fallbench.dynamics.model import pinocchio_for
from fallbench.dynamics.tasks.com import ComTask
from fallbench.policies.base import GainPolicy, Observation
from fallbench.scenario import Scenario
from fallbench.servo import ServoCommand
from fallbench.world import World

class AdaptiveQPPolicy(GainPolicy):
    name = "adaptive_qp"
    needs_contacts = True
    defaults: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(QPConfig)}

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.cfg = QPConfig(**self.params)
        self.P = pinocchio_for(world)
        self.qp = DenseQP(self.cfg.eps_abs, self.cfg.max_iter)
        self.com_ref: np.ndarray | None = None
        self.kp, self.kd = self.default_kp.copy(), self.default_kd.copy()
        self.records: list[dict[str, float]] = []
        self.failures = 0

    def after_impact(self, observation: Observation, q_ref: np.ndarray) -> ServoCommand:
        q, v = self.P.state(observation.qpos, observation.qvel)
        if self.com_ref is None:
            self.com_ref = ComTask.state(self.P.model, self.P.data, q, v)[0]
        points = environment_contacts(self.world.model, observation.data, self.scenario.friction)
        record: dict[str, float] = {"t": observation.t, "qp_contacts": len(points)}
        if points:
            e, e_dot = q_ref - observation.q, -observation.qd
            result, problem = solve_step(self.qp, self.P, q, v, points, q_ref, self.com_ref, e, e_dot,
                                         self.world.torque_limit, self.world.joint_names, self.scenario.control_dt, self.cfg)
            record.update(qp_solved=float(result.solved), qp_iterations=result.iterations, qp_model_ms=result.model_ms,
                          qp_build_ms=result.build_ms, qp_solve_ms=result.solve_ms, qp_selected=len(problem.selected))
            if result.solved:
                self.kp, self.kd = self.default_kp.copy(), self.default_kd.copy()
                # clip the solver's tolerance-sized excursions (~1e-3) out of [0, max]
                self.kp[problem.selected] = np.clip(result.K, 0.0, self.cfg.k_max)
                self.kd[problem.selected] = np.clip(result.B, 0.0, self.cfg.b_max)
            else:
                self.failures += 1
        self.records.append(record)
        return ServoCommand(self.kp, self.kd, q_ref, np.zeros_like(q_ref))

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
