"""`fallbench bench`: the benchmark of fallbench's own speed (the measuring is `fallbench.bench`)."""

from __future__ import annotations

from pathlib import Path

import typer

from fallbench.cli.common import _load, _robot, _select, _strategies, fail
from fallbench.robots import DEFAULT_ROBOT
from fallbench.scenario import DEFAULT_PHYSICS_DT


def bench_command(
    scenario: Path = typer.Option(Path("scenarios/drop.yaml"), help="Scenario file to measure on."),
    point: list[str] = typer.Option(
        ["initial.height=1.0", f"robot={DEFAULT_ROBOT}", f"physics_dt={DEFAULT_PHYSICS_DT}"],
        help="Sweep point of the file: an index, or key=value (repeatable; `robot` matches the point's robot).",
    ),
    pre_impact: str = typer.Option("none", help="Pre-impact strategy of the measured episodes."),
    repeats: int = typer.Option(5, min=1, help="Repeats per measurement (medians are reported)."),
    sweep_runs: int = typer.Option(
        48,
        min=4,
        help="Runs in the 1-job vs 2-job throughput sweep (fewer: the last long run alone on one worker weighs more).",
    ),
    out: Path = typer.Option(Path("reports/bench.md"), help="Markdown table to write."),
    json_path: Path | None = typer.Option(
        None, "--json", help="Also write every figure as one flat JSON object."
    ),
    store: int = typer.Option(
        100_000, "--store", min=0, help="Runs in the synthetic results store measured (0: skip)."
    ),
    e2e_runs: str = typer.Option(
        "20,100",
        help="Comma-separated sizes of the whole-command sweeps, 1 vs 2 jobs (multiples of 4, at most 100; empty: skip).",
    ),
    e2e_repeats: int = typer.Option(
        1, min=1, help="Pairs (1 job, 2 jobs) per whole-command sweep size (medians)."
    ),
    env_scenario: str = typer.Option(
        "examples/learned/falls.yaml",
        help="Scenario file of the Gymnasium environment's throughput (needs the `learned` extra; empty: skip).",
    ),
    env_robot: str | None = typer.Option(
        None, help="Robot of the environment's throughput (default: the file's)."
    ),
    env_episodes: int = typer.Option(4, min=1, help="Episodes of the environment's throughput."),
    report_store: Path | None = typer.Option(
        None, help="A results store whose `fallbench report` is timed, cold and warm (e.g. the main job's)."
    ),
    report_jobs: int = typer.Option(2, min=1, help="--jobs of the timed report."),
) -> None:
    """Measure speed against the physics limit, 2-job scaling, start-up, memory, bytes per run, the results store, the report.

    Prints and writes a table: pure-physics steps/s; per policy, episode time / pure physics and /
    its own physics time, controller cost per control step; adaptive_qp's QP model, build and solve
    times and the reshaping QP's step, with each QP solver; runs/s with 1 and 2 jobs; peak RSS per worker; bytes stored per run; the targets.
    """
    import json

    from fallbench.bench import markdown, run_bench

    chosen = _select(_load([scenario]), point, scenario)
    try:
        sizes = tuple(int(n) for n in e2e_runs.split(",") if n.strip())
    except ValueError:
        fail(f"--e2e-runs {e2e_runs!r}: expected comma-separated numbers of runs")
    if any(n < 4 or n > 100 or n % 4 for n in sizes):
        fail(f"--e2e-runs {e2e_runs!r}: each size must be a multiple of 4 between 4 and 100")
    if report_store is not None and not (report_store / "metrics").is_dir():
        fail(f"--report-store {report_store}: no results store here (run `fallbench run sweep` first)")
    figures = run_bench(
        chosen,
        _strategies(pre_impact)[0],
        repeats,
        sweep_runs,
        progress=lambda m: typer.echo(f"bench: {m}", err=True),
        store_runs=store,
        e2e_runs=sizes,
        e2e_repeats=e2e_repeats,
        env_scenario=Path(env_scenario) if env_scenario else None,
        env_robot=_robot(env_robot),
        env_episodes=env_episodes,
        report_store=report_store,
        report_jobs=report_jobs,
    )
    table = markdown(figures)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(table)
    typer.echo(table)
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(figures, indent=1) + "\n")
    typer.echo(f"wrote {out}" + (f" and {json_path}" if json_path else ""))
