"""The adaptive-gain QP on recorded post-impact states: constraints hold, the selection rule is 002's."""

from __future__ import annotations

import numpy as np
import pytest

import fallbench.policies.adaptive_qp as adaptive
from fallbench.control.adaptive_gains_qp import (
    B_SCALE,
    K_SCALE,
    LAMBDA_SCALE,
    QPConfig,
    build_problem,
    model_terms,
    select_motors,
)
from fallbench.dynamics.contacts import cone_matrix, environment_contacts
from fallbench.dynamics.dense_qp import DenseQP
from fallbench.episode import run_episode
from fallbench.scenario import Scenario

TOL = 1e-4  # relative to the largest term of each row


@pytest.fixture(scope="module")
def post_impact_states():
    """(policy, observation, q_ref) at several control steps after a 1 m drop's impact."""
    states = []
    original = adaptive.AdaptiveQPPolicy.after_impact

    def spy(self, observation, q_ref):
        if len(states) < 40:
            states.append((self, observation, q_ref.copy(), observation.qpos.copy(), observation.qvel.copy(),
                           environment_contacts(self.world.model, observation.data, self.scenario.friction)))
        return original(self, observation, q_ref)

    adaptive.AdaptiveQPPolicy.after_impact = spy
    try:
        run_episode(Scenario(name="drop", duration=0.7, initial={"height": 1.0}), "adaptive_qp")
    finally:
        adaptive.AdaptiveQPPolicy.after_impact = original
    return states[::8]


def test_solution_satisfies_dynamics_torque_limits_and_bounds(post_impact_states) -> None:
    assert len(post_impact_states) >= 4
    for policy, observation, q_ref, qpos, qvel, points in post_impact_states:
        P, world = policy.P, policy.world
        q, v = P.state(qpos, qvel)
        e, e_dot = q_ref - observation.q, -observation.qd
        terms = model_terms(P, q, v, points)
        problem = build_problem(P, terms, points, q_ref, policy.com_ref, e, e_dot, world.torque_limit,
                                world.joint_names, policy.scenario.control_dt, QPConfig())
        status, solved, _, x = DenseQP(QPConfig().eps_abs, QPConfig().max_iter).solve(problem)
        assert solved, status
        nv, n_l, s = problem.n_qdd, problem.n_lambda, problem.selected
        qdd, lam, K, B = x[:nv], x[nv : nv + n_l], x[nv + n_l : nv + n_l + len(s)], x[nv + n_l + len(s) :]
        # Dynamics (eq. 10), all rows: H qdd + C - J' G lambda = tau, tau = 0 on the base.
        G = cone_matrix(points)
        tau = terms.H @ qdd + terms.C - terms.contacts.jacobian.T @ G @ lam
        scale = np.abs(terms.H @ qdd).max() + np.abs(terms.C).max()
        assert np.abs(tau[:6]).max() < TOL * scale
        planned = K * e[s] + B * e_dot[s]
        np.testing.assert_allclose(tau[P.actuated_v[s]], planned, atol=TOL * scale)
        # Torque limits (eq. 12) on every motor, selected and not.
        limits = world.torque_limit
        assert np.all(np.abs(planned) <= limits[s] * (1 + 1e-4) + 1e-6)
        others = np.setdiff1d(np.arange(len(limits)), s)
        assert np.all(np.abs(tau[P.actuated_v[others]]) <= limits[others] * (1 + 1e-4) + 1e-6)
        # Bounds (eq. 13), to the solver's tolerance eps_abs in its scaled variables.
        eps = QPConfig().eps_abs
        assert lam.min() >= -eps * LAMBDA_SCALE and K.min() >= -eps * K_SCALE and B.min() >= -eps * B_SCALE
        assert K.max() <= 2000 + eps * K_SCALE and B.max() <= 2000 + eps * B_SCALE


def test_selection_rule_picks_the_contact_chains(post_impact_states) -> None:
    policy = post_impact_states[0][0]
    names = policy.world.joint_names
    feet = select_motors(policy.P, {"leg_left_6_link", "leg_right_6_link"}, names)
    assert {names[i] for i in feet} == {f"leg_{side}_{i}_joint" for side in ("left", "right") for i in range(1, 7)}
    hand = select_motors(policy.P, {"gripper_left_base_link"}, names)
    expected = {f"arm_left_{i}_joint" for i in range(1, 8)} | {"torso_1_joint", "torso_2_joint"}
    assert {names[i] for i in hand} == expected
