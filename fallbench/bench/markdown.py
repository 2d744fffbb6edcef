"""The figures of `run_bench` as the Markdown of reports/bench.md."""

from __future__ import annotations

from typing import Any

from fallbench.bench.config import FIXED, RESHAPE_PUSH, SOLVER_SHARE, TARGETS, solver_suffix
from fallbench.dynamics.dense_qp import QP_SOLVERS


def _policy_lines(figures: dict[str, Any]) -> list[str]:
    """The heading, pure physics, and one table row per policy (adaptive_qp once per QP solver)."""
    lines = [
        "# fallbench bench",
        "",
        f"Scenario `{figures['scenario']}`, pre-impact `{figures['pre_impact']}`, {figures['cpu_count']} CPUs. "
        f"Pure physics: {figures['physics_steps']} steps in {figures['physics_s'] * 1e3:.1f} ms "
        f"= {figures['physics_steps_per_s']:,.0f} steps/s.",
        "",
        "| policy | episode (ms) | / pure physics | / its own physics | controller per step median (ms) | p99 (ms) |",
        "|---|---|---|---|---|---|",
    ]
    rows = [(p, p) for p in FIXED] + [
        (f"adaptive_qp ({solver})", "adaptive_qp" + solver_suffix(solver)) for solver in QP_SOLVERS
    ]
    for label, p in rows:
        lines.append(
            f"| {label} | {figures[f'episode_s_{p}'] * 1e3:.1f} | {figures[f'episode_ratio_{p}']:.2f} | "
            f"{figures[f'episode_ratio_own_physics_{p}']:.2f} | {figures[f'controller_ms_median_{p}']:.3f} | "
            f"{figures[f'controller_ms_p99_{p}']:.3f} |"
        )
    lines.append("")
    return lines


def _qp_lines(figures: dict[str, Any]) -> list[str]:
    """Per QP solver: adaptive_qp's QP step in parts, and the reshaping QP's step."""
    lines = []
    for solver in QP_SOLVERS:
        x = solver_suffix(solver)
        lines += [
            f"adaptive_qp per QP step with {solver} (medians): model {figures['qp_model_ms_median' + x]:.3f} ms, build "
            f"{figures['qp_build_ms_median' + x]:.3f} ms, solve {figures['qp_solve_ms_median' + x]:.3f} ms; whole step median "
            f"{figures['qp_step_ms_median' + x]:.3f} ms, p99 {figures['qp_step_ms_p99' + x]:.3f} ms; the solver alone: p99 "
            f"{figures['qp_solve_ms_p99' + x]:.3f} ms. Reshaping QP step with {solver} (`{RESHAPE_PUSH.name}`, "
            f"{figures['reshape_steps' + x]:.0f} steps): median {figures['reshape_step_ms_median' + x]:.3f} ms, p99 "
            f"{figures['reshape_step_ms_p99' + x]:.3f} ms; the solver alone: median {figures['reshape_solve_ms_median' + x]:.3f} ms, "
            f"p99 {figures['reshape_solve_ms_p99' + x]:.3f} ms.",
            "",
        ]
    return lines


def _sweep_lines(figures: dict[str, Any]) -> list[str]:
    """Sweep throughput and memory, then the whole commands measured."""
    lines = [
        f"Sweep of {figures['sweep_runs']} runs (4 policies): 1 job {figures['sweep_runs_per_s_1job']:.2f} runs/s, "
        f"2 jobs {figures['sweep_runs_per_s_2job']:.2f} runs/s, speedup {figures['sweep_speedup']:.2f}x "
        f"(worker start and model compile {figures['worker_warmup_s']:.1f} s, not counted). Peak RSS: workers "
        f"{figures['worker_peak_rss_mb']:.0f} MB, main process {figures['main_peak_rss_mb']:.0f} MB. "
        f"Stored per run: {figures['bytes_per_run'] / 1024:.0f} KiB"
        + (
            f" (--timeseries landing; full {figures['bytes_per_run_full'] / 1024:.0f} KiB, "
            f"none {figures['bytes_per_run_none'] / 1024:.1f} KiB)."
            if "bytes_per_run_full" in figures
            else "."
        ),
        "",
    ]
    for runs in sorted(int(k.rsplit("_", 1)[1]) for k in figures if k.startswith("e2e_speedup_")):
        lines += [
            f"Whole command, {runs}-run sweep of shipped drops and pushes (4 policies, no reshaping), start-up "
            f"included: 1 job {figures[f'e2e_sweep_s_1job_{runs}']:.2f} s, 2 jobs {figures[f'e2e_sweep_s_2job_{runs}']:.2f} s, "
            f"speedup {figures[f'e2e_speedup_{runs}']:.2f}x.",
            "",
        ]
    if "run_one_s" in figures:
        lines += [
            f"`fallbench run one` (stiff, whole command): {figures['run_one_s']:.2f} s, of which imports "
            f"{figures['import_s']:.2f} s.",
            "",
        ]
    return lines


def _store_lines(figures: dict[str, Any]) -> list[str]:
    """The results store's timings at N runs, when measured."""
    if "store_runs" not in figures:
        return []
    return [
        f"Results store of {figures['store_runs']:,} runs ({figures['store_parts']} parts, "
        f"{figures['store_table_mb']:.1f} MB; built in {figures['store_build_s']:.1f} s): adding one run "
        f"median {figures['store_add_one_s_median']:.3f} s, worst {figures['store_add_one_s_max']:.3f} s; "
        f"grouped query {figures['store_query_s_median']:.3f} s; filtered read (one scenario, one policy) "
        f"{figures['store_filtered_read_s_median']:.3f} s.",
        "",
    ]


def _environment_lines(figures: dict[str, Any]) -> list[str]:
    if "env_steps" not in figures:
        return []
    return [
        f"Gymnasium environment `fallbench/Fall-v0` on `{figures['env_scenario']}` ({figures['env_episodes']} "
        f"episodes of random actions, {figures['env_steps']} steps): {figures['env_steps_per_s']:.0f} steps/s, "
        f"{figures['env_step_ms']:.2f} ms per step of which {figures['env_physics_ms_per_step']:.2f} ms in mj_step: "
        f"the environment adds {figures['env_overhead'] * 100:.0f} % to its physics.",
        "",
    ]


def _report_lines(figures: dict[str, Any]) -> list[str]:
    """The report's time, cold and warm, when measured."""
    if "report_cold_s" not in figures:
        return []
    return [
        f"`fallbench report` ({figures['report_jobs']} jobs, whole command, {figures['report_files']} files): "
        f"cold {figures['report_cold_s']:.1f} s, warm (no run changed) {figures['report_warm_s']:.1f} s.",
        "",
    ]


def _target_lines(figures: dict[str, Any]) -> list[str]:
    """The targets table: each measured figure against its limit."""
    lines = ["| target | measured | of which the QP solver alone | limit | met |", "|---|---|---|---|---|"]
    for name, (key, comparison, limit) in TARGETS.items():
        share = f"{figures[SOLVER_SHARE[key]]:.3g}" if SOLVER_SHARE.get(key) in figures else ""
        if key in figures:
            lines.append(
                f"| {name} | {figures[key]:.3g} | {share} | {comparison} {limit:g} | {'yes' if figures[f'target_met:{key}'] else 'NO'} |"
            )
        else:
            lines.append(f"| {name} | not measured | | {comparison} {limit:g} | - |")
    return lines


def markdown(figures: dict[str, Any]) -> str:
    """The figures of `run_bench` as the Markdown of reports/bench.md."""
    lines = _policy_lines(figures) + _qp_lines(figures) + _sweep_lines(figures) + _store_lines(figures)
    lines += _environment_lines(figures)
    lines += _report_lines(figures)
    return "\n".join(lines + _target_lines(figures)) + "\n"
