"""The gain policy takes over `timing.takeover_latency` seconds after the first contact, at every
physics step; the baseline stiffness scale sets every policy's default gains."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import simulate_named
from fallbench.scenario import Scenario

SHORT_DROP = Scenario(name="drop", duration=0.2, initial={"height": 0.05})  # feet touch at ~0.10 s


def _switch_step(rec) -> int:
    return round(float(np.nanmin(rec.switch_time)) / rec.scenario.physics_dt)


@pytest.mark.parametrize("physics_dt", [0.001, 0.0005, 0.00025])
def test_takeover_comes_the_latency_after_the_contact(physics_dt: float) -> None:
    scenario = SHORT_DROP.model_copy(update={"physics_dt": physics_dt})
    latency = scenario.timing.takeover_latency
    assert latency == 0.005  # the default: one period of 002's 5 ms loop
    rec = simulate_named(scenario, "zero")
    row = compute_metrics(rec)
    assert row["takeover_delay"] == pytest.approx(latency, abs=1e-9)  # the same in seconds at every step
    contact = round(row["impact_time"] / physics_dt)  # the first sample showing the floor
    assert rec.impact_time == pytest.approx(row["impact_time"])
    switch = contact + round(latency / physics_dt)
    assert _switch_step(rec) == switch
    np.testing.assert_array_equal(rec.kp[switch - 1], rec.world.default_kp)  # still the default gains
    np.testing.assert_array_equal(rec.kp[switch], 0.0)  # the zero policy from then on


def test_zero_latency_takes_over_at_the_next_physics_step() -> None:
    scenario = Scenario.model_validate(SHORT_DROP.model_dump() | {"timing": {"takeover_latency": 0.0}})
    rec = simulate_named(scenario, "zero")
    row = compute_metrics(rec)
    dt = scenario.physics_dt
    contact = round(row["impact_time"] / dt)
    per_control = scenario.physics_steps_per_control
    assert contact % per_control != per_control - 1  # off the control grid: the substeps end early
    assert row["takeover_delay"] == pytest.approx(dt)
    assert row["policy_switch_time"] == pytest.approx((contact + 1) * dt)
    np.testing.assert_array_equal(rec.kp[contact], rec.world.default_kp)
    np.testing.assert_array_equal(rec.kp[contact + 1], 0.0)


@pytest.mark.parametrize("policy", ["stiff", "zero"])
def test_gain_scale_scales_the_default_gains(policy: str) -> None:
    base = simulate_named(SHORT_DROP, policy)
    scaled = simulate_named(
        SHORT_DROP.model_copy(update={"policy_params": {"stiff": {"gain_scale": 2.0}}}), policy
    )
    switch = _switch_step(scaled)
    np.testing.assert_array_equal(scaled.kp[:switch], 2 * base.kp[:switch])  # before impact, every policy
    np.testing.assert_array_equal(scaled.kd[:switch], 2 * base.kd[:switch])
    after = 2 * base.world.default_kp if policy == "stiff" else 0.0
    np.testing.assert_array_equal(scaled.kp[switch:], np.broadcast_to(after, scaled.kp[switch:].shape))
