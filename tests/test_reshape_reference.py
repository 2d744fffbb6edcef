"""The reshaping servo reference and its anti-windup bound (`reference_lead`).

The reference is integrated from the QP's accelerations; where a motor saturates the joint falls
behind, the reference runs on (up to 11.8 x torque limit / kp ahead of the joint on TALOS's 200 N
forward push) and swings the joint across its range once the motor catches up. With
`reference_lead` 1 it stays within torque limit / kp of the joint, the lead at which the servo
saturates anyway.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fallbench.assembly import simulate_named
from fallbench.preimpact.reshape.controller import ReshapeConfig
from fallbench.scenario import Scenario, load_scenario_file

PUSH = Path(__file__).resolve().parents[1] / "scenarios" / "push.yaml"


def _forward_push(reshape: dict[str, float]) -> Scenario:
    """TALOS pushed forward at 200 N, cut to 1.3 s (reshaping from 0.515 s, no impact yet)."""
    (point,) = [
        p
        for p in load_scenario_file(PUSH)
        if p.scenario.name == "push_200N"
        and p.scenario.robot == "talos"
        and p.swept.get("push.direction") == 0
    ]
    params = {**point.scenario.policy_params, "reshape": reshape}
    return point.scenario.model_copy(update={"duration": 1.3, "policy_params": params})


def _largest_lead(reshape: dict[str, float]) -> float:
    """The reference's largest lead on its joint while reshaping, in units of torque limit / kp."""
    recording = simulate_named(_forward_push(reshape), "stiff", "reshape")
    world = recording.world
    assert recording.strategy_start_time is not None
    window = recording.time >= recording.strategy_start_time
    lead = np.abs(recording.q_ref - recording.qpos[:, world.qpos_adr])[window]
    return float((lead / (world.torque_limit / world.default_kp)).max())


@pytest.mark.slow
def test_the_reference_stays_within_the_lead_at_which_the_servo_saturates() -> None:
    # 1.014: the joint moves over the control step after the bound is applied
    assert _largest_lead({"reference_lead": 1.0}) < 1.05
    assert _largest_lead({}) > 5.0  # unbounded, as 002's integration leaves it


def test_negative_bounds_are_refused() -> None:
    for key in ("reference_lead", "joint_limit_braking", "wrist_bend"):
        with pytest.raises(ValueError, match=key):
            ReshapeConfig(**{key: -0.1})
