"""The adaptive-gain QP on recorded post-impact states: dynamics, contact rows, torque limits and
bounds hold in the solution; the selection rule is 002's and persists once a chain is in it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg

import fallbench.postimpact.adaptive_qp.policy as adaptive
from fallbench.assembly import simulate_named
from fallbench.dynamics.contacts import environment_contacts
from fallbench.dynamics.dense_qp import QP_SOLVERS, make_solver
from fallbench.dynamics.model import select_motors
from fallbench.dynamics.terms import model_terms
from fallbench.postimpact.adaptive_qp.qp import QPConfig, build_problem
from fallbench.scenario import Scenario

TOL = 1e-4  # relative to the largest term of each row
FEET = ("leg_left_6_link", "leg_right_6_link")


FAILED_SOLVE = 10  # the post-impact fixture's solve that is reported as failed (counting from 0)


@pytest.fixture(scope="module")
def post_impact_run():
    """A 1 m drop under adaptive_qp, its recording and every control step after its impact:
    (policy, q_ref, qpos, qvel, q, qd, points, selected motors, held torques the policy handed the
    QP, contact bodies, QP result or None, (kp, kd) before the step, the command returned, t). Solve
    number FAILED_SOLVE is reported to the policy as failed."""
    steps = []
    original, solve_step = adaptive.AdaptiveQPPolicy.after_impact, adaptive.solve_step
    solves: list[tuple[np.ndarray, object]] = []  # (held torques, result) of the step's solve

    def solve_spy(*args, **kwargs):
        result, problem = solve_step(*args, **kwargs)
        if len(solves) == FAILED_SOLVE:
            assert result.solved
            result = dataclasses.replace(result, solved=False, status="forced failure")
        solves.append((args[10].copy(), result))
        return result, problem

    def spy(self, observation, q_ref):
        points = environment_contacts(self.world.model, observation.data, self.scenario.friction)
        before, solved = (self.kp.copy(), self.kd.copy()), len(solves)
        command = original(self, observation, q_ref)
        held, result = solves[-1] if len(solves) > solved else (None, None)
        steps.append(
            (
                self,
                q_ref.copy(),
                observation.qpos.copy(),
                observation.qvel.copy(),
                observation.q.copy(),
                observation.qd.copy(),
                points,
                np.flatnonzero(self.selected),
                held,
                set(points.bodies),
                result,
                before,
                command,
                observation.t,
            )
        )
        return command

    adaptive.AdaptiveQPPolicy.after_impact, adaptive.solve_step = spy, solve_spy
    try:
        rec = simulate_named(Scenario(name="drop", duration=0.9, initial={"height": 1.0}), "adaptive_qp")
    finally:
        adaptive.AdaptiveQPPolicy.after_impact, adaptive.solve_step = original, solve_step
    return rec, steps


@pytest.fixture(scope="module")
def post_impact(post_impact_run):
    return post_impact_run[1]


def _solve(step, config: QPConfig = QPConfig()):
    policy, q_ref, qpos, qvel, q_meas, qd_meas, points, selected, held, *_ = step
    robot, world = policy.P, policy.world
    q, v = robot.state(qpos, qvel)
    e, e_dot = q_ref - q_meas, -qd_meas
    terms = model_terms(robot, q, v, points, inertia=True)
    problem = build_problem(
        terms,
        points,
        selected,
        q_ref,
        policy.com_ref,
        e,
        e_dot,
        held,
        world.torque_limit,
        policy.scenario.control_dt,
        config,
    )
    status, solved, _, y = make_solver(
        config.solver, config.eps_abs, config.max_iter, config.max_iter_in
    ).solve(problem)
    assert solved, status
    n_l, n_s = problem.n_lambda, len(selected)
    qdd = problem.acceleration.M @ y + problem.acceleration.m
    return terms, problem, qdd, y[:n_l], y[n_l : n_l + n_s], y[n_l + n_s :], e, e_dot


@pytest.mark.parametrize("solver", QP_SOLVERS)
def test_solution_satisfies_dynamics_contacts_torque_limits_and_bounds(post_impact, solver: str) -> None:
    sample = [s for s in post_impact if s[6]][::10]
    assert len(sample) >= 4
    for step in sample:
        policy, points, s, held = step[0], step[6], step[7], step[8]
        robot, limits = policy.P, policy.world.torque_limit
        terms, problem, qdd, lam, K, B, e, e_dot = _solve(step, QPConfig(solver=solver))
        # Dynamics (eq. 10), all rows: H qdd + C - J' G lambda = tau; tau = 0 on the base, K e + B e_dot
        # on the selected motors (eq. 15), the held PD torque on the others.
        G = scipy.linalg.block_diag(*points.generators)  # forces = G lambda, independently of force_map
        contacts = terms.state.contacts
        tau = terms.H @ qdd + terms.C - contacts.jacobian.T @ G @ lam
        scale = np.abs(terms.H @ qdd).max() + np.abs(terms.C).max()
        assert np.abs(tau[:6]).max() < TOL * scale
        planned = K * e[s] + B * e_dot[s]
        np.testing.assert_allclose(tau[robot.actuated_v[s]], planned, atol=TOL * scale)
        others = np.setdiff1d(np.arange(len(limits)), s)
        np.testing.assert_allclose(tau[robot.actuated_v[others]], held[others], atol=TOL * scale)
        # Contact rows: every contact point's normal acceleration n'(J qdd + J_dot qd) is zero.
        acc = (contacts.jacobian @ qdd + contacts.drift).reshape(-1, 3)
        normal_acc = np.einsum("ij,ij->i", acc, points.normals)
        assert np.abs(normal_acc).max() < 1e-3 * max(1.0, np.abs(qdd).max()), normal_acc
        # Torque limits (eq. 12) and bounds (eq. 13) to the solver's tolerance in its scaled variables.
        assert np.all(np.abs(planned) <= limits[s] * (1 + 1e-4) + 1e-3)
        eps = 10 * QPConfig().eps_abs * problem.scale
        assert (
            np.all(lam >= -eps[: len(lam)])
            and np.all(K >= -eps[len(lam) : len(lam) + len(K)])
            and np.all(B >= -eps[-len(B) :])
        )


def test_both_solvers_reach_the_same_optimum(post_impact) -> None:
    """ProxSuite (to eps_abs) and DAQP (exact active set) on every third recorded state: the same
    cost at their solutions, in the solver's scaled variables."""
    compared = 0
    for step in [s for s in post_impact if s[6]][::3]:
        costs = []
        for solver in QP_SOLVERS:
            _, problem, _, lam, K, B, *_ = _solve(step, QPConfig(solver=solver))
            x = np.concatenate([lam, K, B]) / problem.scale
            costs.append(0.5 * x @ problem.H @ x + problem.g @ x)
        assert abs(costs[0] - costs[1]) <= 1e-4 * max(1.0, abs(costs[0])), costs
        compared += 1
    assert compared >= 10


def test_a_resting_foot_has_zero_normal_acceleration(post_impact) -> None:
    """A step with both feet flat (four corners each): the solution's contact-point accelerations
    have no normal component (tangential motion is a cost)."""
    flat = [s for s in post_impact if len(s[6]) == 8 and s[9] == set(FEET)]
    assert flat
    step = flat[len(flat) // 2]
    terms, problem, qdd, *_ = _solve(step)
    assert problem.A.shape[0] == 6  # three independent rows per flat foot
    contacts = terms.state.contacts
    acc = (contacts.jacobian @ qdd + contacts.drift).reshape(-1, 3)
    normals = step[6].normals
    normal = np.einsum("ij,ij->i", acc, normals)
    assert np.abs(normal).max() < 1e-3 * max(1.0, np.abs(acc).max())


def test_bounds_default_and_options(post_impact) -> None:
    step = [s for s in post_impact if s[6]][5]
    _, problem, *_ = _solve(step)
    n_l, n_s = problem.n_lambda, len(step[7])
    assert np.all(problem.l_box == 0.0) and np.all(
        np.isinf(problem.u_box)
    )  # eq. 13: lambda, K, B >= 0, no upper bound
    capped = QPConfig(k_max=50.0, b_max=5.0, overdamping_ratio=0.1)
    *_, K, B, e, e_dot = _solve(step, capped)
    eps = 1e-3
    assert K.max() <= 50.0 + eps and B.max() <= 5.0 + eps and np.all(B >= 0.1 * K - eps)
    limits = step[0].world.torque_limit[step[7]]
    *_, K, B, e, e_dot = _solve(step, QPConfig(damping_bound_speed=1.0))
    assert np.all(B * np.maximum(np.abs(e_dot[step[7]]), 1.0) <= limits * (1 + 1e-4) + eps)
    assert n_l > 0 and n_s == 12


def test_selection_rule_picks_the_contact_chains(post_impact) -> None:
    policy = post_impact[0][0]
    names = policy.world.joint_names
    feet = select_motors(policy.P, set(FEET), names)
    assert {names[i] for i in feet} == {
        f"leg_{side}_{i}_joint" for side in ("left", "right") for i in range(1, 7)
    }
    hand = select_motors(policy.P, {"gripper_left_base_link"}, names)
    expected = {f"arm_left_{i}_joint" for i in range(1, 8)} | {"torso_1_joint", "torso_2_joint"}
    assert {names[i] for i in hand} == expected


def test_a_leg_stays_selected_after_its_foot_loses_contact(post_impact) -> None:
    policy = post_impact[0][0]
    names = policy.world.joint_names
    selected = [set(step[7]) for step in post_impact]
    assert all(before <= after for before, after in zip(selected, selected[1:]))  # never shrinks
    tested = 0
    for foot, side in zip(FEET, ("left", "right")):
        leg = {names.index(f"leg_{side}_{i}_joint") for i in range(1, 7)}
        first = next(k for k, step in enumerate(post_impact) if foot in step[9])
        lifted = [k for k, step in enumerate(post_impact) if k > first and foot not in step[9]]
        assert all(leg <= selected[k] for k in lifted)
        tested += len(lifted)
    assert tested, "no foot left the floor: the test would not test anything"


def test_the_policy_commands_the_solved_gains_and_keeps_them_on_a_failed_solve(post_impact_run) -> None:
    """The gains the policy hands the servo: on a solved step K and B (clipped at 0) on the selected
    motors and the previous gains elsewhere; on a failed one the previous gains everywhere, the step
    counted in qp_failures and its time in the failure times."""
    rec, steps = post_impact_run
    solved, failed = 0, []
    for step in steps:
        selected, result, (kp, kd), command, t = step[7], *step[10:]
        expected_kp, expected_kd = kp.copy(), kd.copy()  # nothing selected yet, or a failed solve
        if result is not None and result.solved:
            expected_kp[selected], expected_kd[selected] = np.maximum(result.K, 0), np.maximum(result.B, 0)
            solved += 1
        elif result is not None:
            failed.append(t)
        np.testing.assert_array_equal(command.kp, expected_kp)
        np.testing.assert_array_equal(command.kd, expected_kd)
    assert solved > 50 and len(failed) == 1
    assert sum(np.any(s[12].kp != s[11][0]) for s in steps) > 50  # the solves do change the gains
    assert rec.policy_stats["qp_failures"] == 1 and rec.policy_failure_times == failed
