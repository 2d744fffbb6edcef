"""`adaptive_qp_hold`: `adaptive_qp` until the landing is absorbed, then a continuous blend to the
`stiff` gains; a G1 drop that `stiff` survives and `adaptive_qp` does not is survived."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.analysis.metrics import compute_metrics
from fallbench.assembly import run_world, simulate_named
from fallbench.postimpact.adaptive_qp.policy import AdaptiveQPPolicy
from fallbench.postimpact.adaptive_qp_hold import (
    AdaptiveQPHoldPolicy,
    HoldConfig,
    absorbed,
    blend_weight,
    blended_reference,
)
from fallbench.registry import POLICIES
from fallbench.scenario import Scenario

G1_DROP = Scenario(name="drop", robot="g1", initial={"height": 0.5})  # stiff stands, adaptive_qp falls


@pytest.fixture(scope="module")
def hold_run():
    """The G1 0.5 m drop under adaptive_qp_hold: the policy, its recording, and every command it
    returned with its time (s) and the base's vertical velocity (m/s) at that step."""
    commands = []
    original = AdaptiveQPHoldPolicy.after_impact

    def spy(self, observation, q_ref):
        command = original(self, observation, q_ref)
        commands.append((observation.t, float(observation.qvel[2]), command))
        spy.policy = self
        return command

    AdaptiveQPHoldPolicy.after_impact = spy
    try:
        recording = simulate_named(G1_DROP, "adaptive_qp_hold")
    finally:
        AdaptiveQPHoldPolicy.after_impact = original
    return spy.policy, recording, commands


def test_blend_weight_is_linear_and_clipped() -> None:
    assert blend_weight(-0.01, 0.05) == 0.0
    assert blend_weight(0.0, 0.05) == 0.0
    assert blend_weight(0.025, 0.05) == pytest.approx(0.5)
    assert blend_weight(0.05, 0.05) == 1.0 and blend_weight(1.0, 0.05) == 1.0
    assert blend_weight(0.0, 0.0) == 1.0  # no blend: a step


def test_absorbed_by_speed_or_at_the_latest_after_hold_after() -> None:
    config = HoldConfig(hold_speed=1.0, hold_after=0.2)
    assert not absorbed(0.01, -4.0, config)
    assert not absorbed(0.01, -1.0, config)
    assert absorbed(0.01, -0.99, config)
    assert absorbed(0.01, 0.5, config)
    assert absorbed(0.2, -4.0, config)


def test_blended_reference_blends_the_two_pd_torques() -> None:
    rng = np.random.default_rng(0)
    kp_from, kp_to = rng.uniform(0, 50, 8), rng.uniform(100, 600, 8)
    kp_from[0] = 0.0  # a gain the QP drove to zero
    q_from, q_to, q = rng.normal(size=8), rng.normal(size=8), rng.normal(size=8)
    for share in (0.0, 0.3, 0.7, 0.999):
        kp = (1 - share) * kp_from + share * kp_to
        torque = kp * (blended_reference(share, kp_from, q_from, kp_to, q_to) - q)
        expected = (1 - share) * kp_from * (q_from - q) + share * kp_to * (q_to - q)
        np.testing.assert_allclose(torque, expected, atol=1e-9)
    np.testing.assert_array_equal(blended_reference(0.0, kp_from, q_from, kp_to, q_to)[1:], q_from[1:])
    np.testing.assert_array_equal(blended_reference(1.0, kp_from, q_from, kp_to, q_to), q_to)


def test_registered_beside_an_unchanged_adaptive_qp() -> None:
    assert POLICIES["adaptive_qp"] is AdaptiveQPPolicy
    assert POLICIES["adaptive_qp_hold"] is AdaptiveQPHoldPolicy
    assert set(AdaptiveQPPolicy.defaults) < set(AdaptiveQPHoldPolicy.defaults)


def test_qp_parameters_reach_the_inner_qp() -> None:
    scenario = Scenario(
        name="drop", policy_params={"adaptive_qp_hold": {"w_com": 3.0, "solver": "daqp", "hold_after": 0.1}}
    )
    policy = AdaptiveQPHoldPolicy(run_world(scenario), scenario)
    assert policy.qp.config.w_com == 3.0 and policy.qp.config.solver == "daqp"
    assert policy.config.hold_after == 0.1


def test_the_qp_decides_until_the_absorption(hold_run) -> None:
    policy, _, commands = hold_run
    start = policy.absorption.t
    before = [(t, vz) for t, vz, _ in commands if t < start - 1e-9]
    assert before and policy.qp.stats()["qp_steps"] == len(before)  # one QP solve per step, then none
    assert all(vz <= -policy.config.hold_speed for _, vz in before)
    t, vz, _ = next(c for c in commands if c[0] >= start - 1e-9)
    assert vz > -policy.config.hold_speed or t - policy.takeover >= policy.config.hold_after


def test_after_the_blend_the_stiff_gains_hold_the_landing_crouch(hold_run) -> None:
    policy, _, commands = hold_run
    assert policy.config.hold_pose == "landing"
    done = policy.absorption.t + policy.config.blend_time
    after = [command for t, _, command in commands if t >= done - 1e-9]
    assert len(after) > 100
    for command in after:
        np.testing.assert_array_equal(command.kp, policy.default_kp)
        np.testing.assert_array_equal(command.kd, policy.default_kd)
        np.testing.assert_array_equal(command.q_ref, policy.absorption.q)
        np.testing.assert_array_equal(command.qd_ref, 0.0)


def test_the_blend_is_continuous(hold_run) -> None:
    """No gain step: consecutive commands from the absorption on differ by at most the blend's
    rate times one control period, and the first hold command repeats the QP's last gains and
    reference (the impact pose)."""
    policy, _, commands = hold_run
    start, config = policy.absorption.t, policy.config
    index = next(i for i, c in enumerate(commands) if c[0] >= start - 1e-9)
    last_qp, first_hold = commands[index - 1][2], commands[index][2]
    np.testing.assert_array_equal(first_hold.kp, last_qp.kp)
    np.testing.assert_array_equal(first_hold.kd, last_qp.kd)
    selected = first_hold.kp > 0
    np.testing.assert_allclose(first_hold.q_ref[selected], last_qp.q_ref[selected], atol=1e-12)
    dt = policy.scenario.control_dt
    kp_rate = np.abs(policy.default_kp - policy.absorption.kp) / config.blend_time
    kd_rate = np.abs(policy.default_kd - policy.absorption.kd) / config.blend_time
    for (t0, _, a), (t1, _, b) in zip(commands[index:], commands[index + 1 :], strict=False):
        step = max(t1 - t0, dt)
        assert np.all(np.abs(b.kp - a.kp) <= kp_rate * step + 1e-9)
        assert np.all(np.abs(b.kd - a.kd) <= kd_rate * step + 1e-9)
    assert np.abs(policy.default_kp - policy.absorption.kp).max() > 1.0  # the blend had work to do


@pytest.mark.slow
def test_a_g1_drop_stiff_survives_is_survived(hold_run) -> None:
    _, recording, _ = hold_run
    assert not compute_metrics(simulate_named(G1_DROP, "stiff"))["fell"]
    assert compute_metrics(simulate_named(G1_DROP, "adaptive_qp"))["fell"]  # the problem this solves
    row = compute_metrics(recording)
    assert not row["fell"] and row["settled"]
    assert 0.0 < row["hold_start"] < HoldConfig.hold_after


G1_TIP_OVER = Scenario(  # 004's 370 N forward push scaled to G1 by mass: the knees touch first
    name="push_004", robot="g1", push={"force": 137, "duration": 0.1, "start": 0.1, "direction": 0}
)


@pytest.mark.slow
def test_an_impact_off_the_feet_is_held_at_once() -> None:
    """With `qp_impacts: feet` (default) a first impact on the knees is not a landing: no QP is
    solved, the hold starts at the takeover and the fall is `stiff`'s; with `any` the QP takes it."""
    stiff = compute_metrics(simulate_named(G1_TIP_OVER, "stiff"))
    held = compute_metrics(simulate_named(G1_TIP_OVER, "adaptive_qp_hold"))
    assert held["first_impact_group"] == "knees" and held["fell"] and stiff["fell"]
    assert held["qp_steps"] == 0 and held["hold_start"] == 0.0
    for measure in ("contact_force_peak_head", "contact_force_peak_torso", "vulnerable_hits"):
        assert held[measure] == pytest.approx(stiff[measure], abs=1.0)
    scenario = G1_TIP_OVER.model_copy(update={"policy_params": {"adaptive_qp_hold": {"qp_impacts": "any"}}})
    absorbing = compute_metrics(simulate_named(scenario, "adaptive_qp_hold"))
    assert absorbing["qp_steps"] > 0 and absorbing["hold_start"] > 0.0
