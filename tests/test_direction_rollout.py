"""The short-rollout predictor of `direction`: a rollout leaves the running fall,
the strategy and the model as they were, and predicts a forced step's fall closer to the simulated
one than 004's pendulum does."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.analysis.safe_regions import angle_between
from fallbench.assembly import simulate_named
from fallbench.preimpact.direction.rollout import predict_by_rollout
from fallbench.preimpact.direction.strategy import DirectionStrategy
from fallbench.scenario import Scenario

STEP = Scenario(  # a forced step in free space (the far post only makes the outcome metrics run)
    name="dir_rollout_step",
    duration=2.0,
    push={"force": 393, "duration": 0.1, "start": 0.1, "direction": 0},
    obstacles=[{"type": "cylinder", "pos": [-5.0, 5.0, 0.05], "radius": 0.05, "height": 0.1}],
    policy_params={"direction": {"mode": "take_step", "step_length": 0.45, "step_bearing": 45}},
)
DATA_FIELDS = ("time", "qpos", "qvel", "act", "ctrl", "qacc_warmstart", "sensordata", "xfrc_applied")


def _snapshot(strategy: DirectionStrategy, data: mujoco.MjData) -> dict[str, Any]:
    model = strategy.world.model
    kept: dict[str, Any] = {f"data.{f}": np.copy(getattr(data, f)) for f in DATA_FIELDS}
    kept |= {f"strategy.{name}": value for name, value in strategy.snapshot().items()}
    kept |= {"q_ref values": strategy.q_ref.copy(), "qd_ref values": strategy.qd_ref.copy()}
    kept |= {  # the kinematics the strategy's present RobotState reads
        "pinocchio frames": np.array([placement.homogeneous for placement in strategy.P.data.oMf]),
        "pinocchio com": strategy.P.data.com[0].copy(),
    }
    kept |= {
        f"model.{f}": np.copy(getattr(model, f))
        for f in ("actuator_gainprm", "actuator_biasprm", "geom_contype", "geom_conaffinity")
    }
    kept["model.opt.timestep"] = np.array(model.opt.timestep)
    return kept


def _unchanged(before: dict[str, Any], after: dict[str, Any]) -> list[str]:
    """Names of the snapshot entries that differ (arrays by value, the strategy's objects by identity)."""
    return [
        key
        for key, value in before.items()
        if (
            not np.array_equal(value, after[key])
            if isinstance(value, np.ndarray)
            else value is not after[key] and value != after[key]
        )
    ]


@pytest.fixture(scope="module")
def forced_step() -> dict[str, Any]:
    """The forced step's run (pendulum plan, as shipped), with the chosen step also predicted by a
    rollout at the control trigger, and what the rollout changed."""
    found: dict[str, Any] = {}
    plan = DirectionStrategy._plan

    def plan_and_roll_out(self: DirectionStrategy, t: float, data: mujoco.MjData, *args: Any) -> None:
        plan(self, t, data, *args)
        assert self.plan is not None
        before = _snapshot(self, data)
        found["rollout"] = predict_by_rollout(self, data, t, self.plan.chosen).direction
        found["changed"] = _unchanged(before, _snapshot(self, data))

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(DirectionStrategy, "_plan", plan_and_roll_out)
        rec = simulate_named(STEP, "stiff", "direction")
    assert rec.strategy is not None and rec.strategy.plan is not None
    found["chosen"] = rec.strategy.plan.chosen
    found["row"] = compute_metrics(rec)
    return found


def test_a_rollout_leaves_the_fall_the_strategy_and_the_model_as_they_were(forced_step) -> None:
    """The copy of the state, the strategy's swing state and references, the servo gains and the
    objects' contact flags the rollout changed, and Pinocchio's kinematics, are as before."""
    assert math.isfinite(forced_step["rollout"])
    assert forced_step["changed"] == []


def test_the_rollout_predicts_a_forced_step_better_than_the_pendulum(forced_step) -> None:
    """393 N forward, a 0.45 m step 45 deg off the predicted fall, run without inertia shaping: the
    pendulum lets the step land at the fitted time on the planned polygon (13 deg off the fall);
    the rollout swings the foot as the strategy does and predicts from where it landed (1 deg)."""
    chosen, row = forced_step["chosen"], forced_step["row"]
    assert chosen.kind == "take_step" and row["actual_fall_end"] == "touchdown"
    actual = math.radians(row["actual_fall_direction_deg"])
    pendulum_error = math.degrees(angle_between(chosen.direction, actual))
    rollout_error = math.degrees(angle_between(forced_step["rollout"], actual))
    assert rollout_error < 0.5 * pendulum_error
