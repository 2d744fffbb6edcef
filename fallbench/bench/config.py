"""What `fallbench bench` measures and against what: the policies, the reshaping QP's fall, the QP
solvers' figure keys, the targets docs/bench.md states; the timing helper."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from fallbench.dynamics.dense_qp import QP_SOLVERS
from fallbench.scenario import Scenario

POLICIES = ("stiff", "oneshot", "zero", "adaptive_qp")
FIXED = ("stiff", "oneshot", "zero")
# the reshaping QP's bench fall: a front push; reshaping runs from fall detection to the first impact (~1.4 s)
RESHAPE_PUSH = Scenario(
    name="bench_reshape_push",
    duration=1.45,
    pre_impact=["reshape"],
    push={"force": 370.0, "duration": 0.1, "start": 0.1, "direction": 0.0},
)


def solver_suffix(solver: str) -> str:
    """Figure-key suffix of a QP solver: none for the default (ProxSuite), `_daqp` for DAQP."""
    return "" if solver == QP_SOLVERS[0] else f"_{solver}"


def with_qp_solver(scenario: Scenario, solver: str) -> Scenario:
    """The scenario with both QPs (adaptive_qp, reshape) on `solver`."""
    params = {
        name: {**scenario.policy_params.get(name, {}), "solver": solver}
        for name in ("adaptive_qp", "reshape")
    }
    return scenario.model_copy(update={"policy_params": {**scenario.policy_params, **params}})


# target name -> (figure key, comparison, limit): the targets docs/bench.md states
TARGETS: dict[str, tuple[str, str, float]] = {
    **{f"{p} episode / pure physics": (f"episode_ratio_{p}", "<=", 1.15) for p in FIXED},
    **{
        f"adaptive_qp ({solver}) episode / pure physics": (
            f"episode_ratio_adaptive_qp{solver_suffix(solver)}",
            "<=",
            2.0,
        )
        for solver in QP_SOLVERS
    },
    **{
        f"adaptive_qp ({solver}) QP step median (ms)": (
            f"qp_step_ms_median{solver_suffix(solver)}",
            "<=",
            0.3,
        )
        for solver in QP_SOLVERS
    },
    **{
        f"adaptive_qp ({solver}) QP step p99 (ms)": (f"qp_step_ms_p99{solver_suffix(solver)}", "<=", 1.0)
        for solver in QP_SOLVERS
    },
    **{
        f"reshape ({solver}) QP step median (ms)": (
            f"reshape_step_ms_median{solver_suffix(solver)}",
            "<=",
            1.0,
        )
        for solver in QP_SOLVERS
    },
    "2-job / 1-job sweep throughput": ("sweep_speedup", ">=", 1.8),
    "worker peak RSS (MB)": ("worker_peak_rss_mb", "<=", 500.0),
    "20-run sweep, 2 jobs vs 1, whole command": ("e2e_speedup_20", ">=", 1.6),
    "100-run sweep, 2 jobs vs 1, whole command": ("e2e_speedup_100", ">=", 1.9),
    "`run one`, whole command (s)": ("run_one_s", "<=", 1.0),
    "store: add one run, worst of the adds (s)": ("store_add_one_s_max", "<=", 2.0),
    "report of the given store, cold (s)": ("report_cold_s", "<=", 30.0),
    "report of the given store, warm (s)": ("report_warm_s", "<=", 10.0),
    "store: grouped query (s)": ("store_query_s_median", "<=", 1.0),
    "Gymnasium env: time added to its physics (fraction)": ("env_overhead", "<=", 0.30),
}
# a QP target's figure -> the same figure of the solver's part alone (a floor that no work outside the solver lowers)
SOLVER_SHARE = {
    f"{step}{solver_suffix(solver)}": f"{solve}{solver_suffix(solver)}"
    for solver in QP_SOLVERS
    for step, solve in (
        ("qp_step_ms_median", "qp_solve_ms_median"),
        ("qp_step_ms_p99", "qp_solve_ms_p99"),
        ("reshape_step_ms_median", "reshape_solve_ms_median"),
    )
}


def median_time(function: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def judge_targets(figures: dict[str, Any]) -> None:
    """`target_met:<key>` for every target whose figure was measured, in place."""
    for key, comparison, limit in TARGETS.values():
        if key in figures:
            value = figures[key]
            figures[f"target_met:{key}"] = bool(value <= limit if comparison == "<=" else value >= limit)
