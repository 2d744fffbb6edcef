"""The gain policy takes over at the physics step after first contact, not at the next control step;
the baseline stiffness scale sets every policy's default gains."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.registry import simulate_named
from fallbench.scenario import Scenario

SHORT_DROP = Scenario(name="drop", duration=0.2, initial={"height": 0.05})  # feet touch at ~0.10 s


def test_takeover_at_the_contact_step() -> None:
    rec = simulate_named(SHORT_DROP, "zero")
    row = compute_metrics(rec)
    dt = SHORT_DROP.physics_dt
    contact = round(row["impact_time"] / dt)  # physics step whose contact sensors first found the floor
    assert (
        contact % SHORT_DROP.physics_steps_per_control != SHORT_DROP.physics_steps_per_control - 1
    )  # off the grid
    assert row["takeover_delay"] == pytest.approx(dt)
    assert row["policy_switch_time"] == pytest.approx((contact + 1) * dt)
    np.testing.assert_array_equal(
        rec.kp[contact], rec.world.default_kp
    )  # the contact step: still the default gains
    np.testing.assert_array_equal(rec.kp[contact + 1], 0.0)  # the next physics step: the zero policy
    np.testing.assert_allclose(rec.switch_time, (contact + 1) * dt)


@pytest.mark.parametrize("policy", ["stiff", "zero"])
def test_gain_scale_scales_the_default_gains(policy: str) -> None:
    base = simulate_named(SHORT_DROP, policy)
    scaled = simulate_named(
        SHORT_DROP.model_copy(update={"policy_params": {"stiff": {"gain_scale": 2.0}}}), policy
    )
    switch = round(scaled.impact_time / SHORT_DROP.physics_dt)
    np.testing.assert_array_equal(scaled.kp[:switch], 2 * base.kp[:switch])  # before impact, every policy
    np.testing.assert_array_equal(scaled.kd[:switch], 2 * base.kd[:switch])
    after = 2 * base.world.default_kp if policy == "stiff" else 0.0
    np.testing.assert_array_equal(scaled.kp[switch:], np.broadcast_to(after, scaled.kp[switch:].shape))
