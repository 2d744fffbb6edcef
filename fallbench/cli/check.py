"""`fallbench check`: the CI suite's metrics against the committed baseline."""

from __future__ import annotations

from pathlib import Path

import typer

from fallbench.cli.common import PRE_IMPACT_HELP, _load, _policies, _strategies, fail


def check_command(
    suite: list[Path] = typer.Option(
        [Path("scenarios/ci.yaml")], help="Scenario files of the regression suite."
    ),
    baseline: Path = typer.Option(Path("baselines/ci.csv"), help="Baseline metrics (CSV)."),
    tolerances: Path = typer.Option(Path("baselines/tolerances.yaml"), help="Per-metric tolerances (YAML)."),
    policies: str = typer.Option("stiff,oneshot,zero,adaptive_qp", help="Comma-separated gain policies."),
    pre_impact: str = typer.Option("none", help=PRE_IMPACT_HELP),
    results: Path = typer.Option(Path("results/ci"), help="Results store for the suite's runs."),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="Parallel worker processes."),
    update: bool = typer.Option(False, help="Rewrite the baseline from this run instead of comparing."),
) -> None:
    """Run the suite (or reuse its stored runs) and compare every metric with the baseline.

    Exit 0 with a one-line summary when nothing regressed; exit 1 with a table of regressions
    (a NaN, a missing run, a new failure or a metric outside tolerance) otherwise; exit 2 before
    running anything when the baseline is missing or corrupt (a NaN, an infinite or non-numeric
    value, a missing column).
    """
    from fallbench.results.regress import (
        BaselineError,
        baseline_frame,
        changed_versions,
        compare,
        load_tolerances,
        read_baseline,
        write_baseline,
    )
    from fallbench.results.runner import expand, run_sweep

    try:
        limits = load_tolerances(tolerances)
    except (OSError, ValueError) as exc:
        fail(f"{tolerances}: {exc}")
    points, chosen, strategies = _load(suite), _policies(policies), _strategies(pre_impact)
    expected = None
    if not update:  # a missing or corrupt baseline is bad input: say so before running anything
        if not baseline.exists():
            fail(f"{baseline}: no baseline (create it with `fallbench check --update`)")
        try:
            expected = read_baseline(baseline, limits)
        except BaselineError as exc:
            fail(str(exc))
    table = run_sweep(expand(points, chosen, strategies), results, jobs=jobs, progress=False)
    now = baseline_frame(table, limits)
    if update:
        write_baseline(now, baseline)
        typer.echo(f"baseline updated: {baseline} ({len(now)} cases, {len(limits.metrics)} metrics)")
        return
    changed = changed_versions(expected, now)
    if changed:  # said first: a change here moves numbers without any change of ours
        typer.echo(f"software changed since {baseline} was recorded: {'; '.join(changed)}", err=True)
    regressions = compare(expected, now, limits)
    if regressions:
        _echo_regressions(regressions)
        typer.echo(f"{len(regressions)} regression(s) against {baseline}", err=True)
        raise typer.Exit(1)
    typer.echo(
        f"check ok: {len(now)} cases x {len(limits.per_run)} per-run metrics, "
        f"{len(limits.distribution)} metrics over seeds, within tolerance of {baseline}"
    )


def _echo_regressions(regressions) -> None:
    typer.echo(f"{'case':<48} {'metric':<32} {'baseline':>12} {'now':>12} {'change':>10}  tolerance")
    for r in regressions:
        typer.echo(
            f"{r.case:<48} {r.metric:<32} {r.baseline!s:>12.12} {r.now!s:>12.12} {r.change:>10}  {r.tolerance}"
        )
