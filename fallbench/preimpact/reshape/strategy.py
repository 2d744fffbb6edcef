"""`reshape`: posture reshaping and landing-point control of 002 Sec. IV / 000 Sec. IV
(the controller itself is `fallbench.preimpact.reshape.controller.ReshapeController`)."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from fallbench.dynamics.dense_qp import QP_SOLVERS
from fallbench.preimpact.base import Strategy
from fallbench.preimpact.reshape.controller import PIVOTS, RESHAPE_PARAMS, ReshapeController
from fallbench.scenario import Scenario
from fallbench.sim.impacts import hand_first_contact
from fallbench.sim.recorder import Recording
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World


class ReshapeStrategy(Strategy):
    name = "reshape"
    defaults = RESHAPE_PARAMS
    per_chain_switching = True
    choices = {"pivot": PIVOTS, "solver": QP_SOLVERS}
    robot_needs = ("arms",)  # the hands it places on the floor
    stat_columns: dict[str, Any] = {  # the controller's `stats`
        "preimpact_qp_ms_median": float("nan"),
        "preimpact_qp_ms_p99": float("nan"),
        "preimpact_qp_solve_ms_median": float("nan"),
        "preimpact_qp_solve_ms_p99": float("nan"),
        "preimpact_qp_failures": 0,
        "preimpact_qp_steps": 0,
        "fall_class_at_detection": "",
        "fall_class_before_impact": "",
        # `metrics`: m, from the point the strategy aimed each hand at to its first contact, and their mean
        "landing_error_left": float("nan"),
        "landing_error_right": float("nan"),
        "landing_error": float("nan"),
    }

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.controller = ReshapeController(world, scenario, scenario.policy_params.get(self.name))
        self.start_margin = self.controller.config.start_margin

    def start(self, t: float, data: mujoco.MjData) -> None:
        self.controller.start(
            data.qpos, data.qvel, data.qpos[self.world.qpos_adr], data.qvel[self.world.qvel_adr]
        )

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        return self.controller.step(t, data, data.qpos, data.qvel)

    def landing_target(self, side: str, t: float) -> np.ndarray | None:
        """The point (m, world) this arm's hand was aimed at, last chosen at or before t, if any."""
        return self.controller.bip_before(side, t)

    def stats(self) -> dict[str, Any]:
        return self.controller.stats()

    def metrics(self, recording: Recording) -> dict[str, Any]:
        """The landing error of each hand (m): its first contact point from the point it was aimed
        at then (`landing_error_left`, `_right`), and their mean over the hands that have one."""
        errors: dict[str, float] = {}
        for side in self.world.robot.arms:
            contact = hand_first_contact(self.world, recording.first_contacts, side)
            target = self.landing_target(side, contact[1].t) if contact else None
            if contact is not None and target is not None:
                errors[side] = float(np.linalg.norm(contact[1].point - target))
        row: dict[str, Any] = {
            f"landing_error_{side}": errors.get(side, float("nan")) for side in ("left", "right")
        }
        row["landing_error"] = float(np.mean(list(errors.values()))) if errors else float("nan")
        return row
