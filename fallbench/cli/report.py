"""Commands that read the results store: `fallbench report`, `render`, `compare` and `results`."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from fallbench.cli.common import fail


def report_command(
    results: Path = typer.Option(Path("results"), help="Results store folder."),
    out: Path = typer.Option(
        Path("reports"), help="Folder for figures (PNG; SVG with --svg), index.html and summary.md."
    ),
    progress: bool = typer.Option(True, help="Show a progress bar."),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="Processes drawing figures in parallel."),
    svg: bool = typer.Option(False, "--svg", help="Also write every figure as SVG (vector) next to its PNG."),
    filmstrips: str = typer.Option(
        "family",
        help="Falls rendered per family: `family` (the typical fall of the best strategy + policy and of "
        "none + stiff, and the worst fall) or `all` (the typical and the worst fall of every strategy + policy).",
    ),
    paper_figures: str = typer.Option(
        "chosen",
        help="Points with 002's figures per family: `chosen` (the point of its worst shown fall) or `all` "
        "(every point whose runs have what they need).",
    ),
) -> None:
    """Answer first (forest plots, rankings), then per family its representative falls and the papers'
    figures per point, sweep comparisons and the claims; figures whose runs did not change are kept."""
    from fallbench.report import Options, build_report
    from fallbench.results.store import consolidate

    if (results / "runs").is_dir():
        consolidate(results)  # runs stored by `run one` or an interrupted sweep
    from fallbench.report import PAPER_FIGURES
    from fallbench.report.filmstrips import SCOPES

    if filmstrips not in SCOPES:
        fail(f"--filmstrips: {filmstrips!r} is not one of {', '.join(SCOPES)}")
    if paper_figures not in PAPER_FIGURES:
        fail(f"--paper-figures: {paper_figures!r} is not one of {', '.join(PAPER_FIGURES)}")
    options = Options(jobs=jobs, svg=svg, filmstrips=filmstrips, paper_figures=paper_figures)
    try:
        paths = build_report(results, out, progress=progress and sys.stderr.isatty(), options=options)
    except FileNotFoundError as exc:
        fail(str(exc))
    typer.echo(
        f"wrote {len(paths)} files ({options.drawn} figures drawn, {options.cached} unchanged); "
        f"open {out}/index.html (summary in {out}/summary.md)"
    )


def render_command(
    run_id: str = typer.Argument(
        ...,
        help="Run id (or a unique prefix of one), as `fallbench results --columns run_id,point,policy` lists them.",
    ),
    vs: str | None = typer.Option(
        None,
        "--vs",
        help="A second run, shown side by side on the same clock and camera (e.g. none vs reshape).",
    ),
    out: Path = typer.Option(Path("fall.mp4"), help="Video to write: .mp4 (H.264) or .gif."),
    results: Path = typer.Option(Path("results"), help="Results store folder."),
    fps: int = typer.Option(25, min=1, max=100, help="Frames per second of the video."),
    speed: float = typer.Option(
        1.0, min=0.05, max=4.0, help="Playback speed: 0.25 = four times slower than real time."
    ),
) -> None:
    """Render a stored fall with MuJoCo's offscreen renderer (EGL on headless Linux) as a video."""
    from fallbench.report.render import RenderUnavailable, ReplayMissing, video

    if out.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--out {out}: expected a .mp4 or .gif file")
    try:
        path = video(results, [run_id] + ([vs] if vs else []), out, fps=fps, speed=speed)
    except (RenderUnavailable, ReplayMissing) as exc:
        fail(str(exc))
    typer.echo(f"wrote {path}")


def _selected_runs(results: Path, where: str | None, option: str):
    """The store's runs (consolidated first), those matching `where` (a pandas query) if given."""
    from fallbench.results.store import consolidate, load_metrics

    if (results / "runs").is_dir():
        consolidate(results)
    try:
        table = load_metrics(results)
    except FileNotFoundError as exc:
        fail(str(exc))
    if table.empty:
        fail(f"{results}: the results store has no runs")
    if where:
        try:
            table = table.query(where)
        except Exception as exc:  # pandas raises many types for a bad expression
            fail(f"{option} {where!r}: {exc}")
    return table


def compare_command(
    store_a: Path = typer.Argument(..., metavar="A", help="Results store A (before)."),
    store_b: Path | None = typer.Argument(
        None, metavar="[B]", help="Results store B (after); default: A, with --where-a and --where-b."
    ),
    where_a: str | None = typer.Option(
        None,
        help="pandas query selecting A's runs, as `fallbench results --where`, e.g. \"`version:code` == 'abc123'\".",
    ),
    where_b: str | None = typer.Option(None, help="pandas query selecting B's runs."),
    key: str = typer.Option(
        "robot,scenario,point,seed,pre_impact,policy",
        help="Comma-separated columns on which a run of A pairs with a run of B.",
    ),
    out: Path | None = typer.Option(
        None, help="Folder for compare.md, compare.csv and compare.png (default: print only)."
    ),
    fail_on: str = typer.Option("none", help="worse: exit 1 if any change is worse; none: exit 0."),
) -> None:
    """Paired change B - A of each headline damage measure per robot, family, strategy and policy.

    Runs pair when they share the --key columns and both ran ok. Per group: the median change
    (fell, joint_limit_hits: the mean) with a 95 % bootstrap interval, and a verdict: better,
    worse (the interval clear of 0; lower is better except knee_limit_margin), no clear change,
    or no change (every paired difference 0).
    """
    from fallbench.report.compare import compare, display_table, summary_line, write

    if fail_on not in ("none", "worse"):
        fail(f"--fail-on: unknown value {fail_on!r}; known: none, worse")
    if store_b is None and not (where_a or where_b):
        fail("compare needs two stores (A B), or one store with --where-a and --where-b")
    runs_a = _selected_runs(store_a, where_a, "--where-a")
    runs_b = _selected_runs(store_b or store_a, where_b, "--where-b")
    try:
        comparison = compare(runs_a, runs_b, tuple(k.strip() for k in key.split(",") if k.strip()))
    except ValueError as exc:
        fail(f"--key: {exc}")
    if comparison.pairs == 0:
        fail(f"A and B share no run that ran ok in both (paired on {key})")
    typer.echo(display_table(comparison).to_string(index=False))
    typer.echo("\n" + summary_line(comparison))
    if out is not None:
        names = [
            f"{store_a}" + (f" where {where_a}" if where_a else ""),
            f"{store_b or store_a}" + (f" where {where_b}" if where_b else ""),
        ]
        paths = write(comparison, out, *names)
        typer.echo(f"wrote {', '.join(str(p) for p in paths)}")
    if fail_on == "worse" and len(comparison.worse):
        typer.echo(f"{len(comparison.worse)} changes are worse (--fail-on worse)", err=True)
        raise typer.Exit(1)


def results_command(
    results: Path = typer.Option(Path("results"), help="Results store folder."),
    where: str | None = typer.Option(
        None, help="pandas query, e.g. \"policy == 'zero' and imu_peak_z > 300\"."
    ),
    columns: str = typer.Option(
        "point,policy,status,imu_peak_z,knee_limit_margin,torque_demand_ratio_max,fell",
        help="Comma-separated columns.",
    ),
    fmt: str = typer.Option("table", "--format", help="table, csv or json."),
    failed: bool = typer.Option(False, help="Only failed or diverged runs, with their errors."),
    scenario: str | None = typer.Option(
        None, help="Comma-separated scenario names (read from the store by push-down)."
    ),
    policy: str | None = typer.Option(None, help="Comma-separated policies."),
    pre_impact: str | None = typer.Option(None, help="Comma-separated pre-impact strategies."),
    robot: str | None = typer.Option(None, help="Comma-separated robots."),
    sql: str | None = typer.Option(
        None,
        help='SQL on the view `runs` (DuckDB), e.g. "SELECT policy, median(imu_peak_z) FROM runs GROUP BY policy"; replaces the other selection options.',
    ),
) -> None:
    """List runs and metrics from the results store (runs stored since the last sweep are added first)."""
    from fallbench.results.store import consolidate, load_metrics, query

    if (results / "runs").is_dir():
        consolidate(results)
    try:
        if sql:
            table = query(results, sql)
            columns = ",".join(map(str, table.columns))
        else:
            filters = {"scenario": scenario, "policy": policy, "pre_impact": pre_impact, "robot": robot}
            table = load_metrics(
                results,
                **{
                    k: [v.strip() for v in text.split(",") if v.strip()]
                    for k, text in filters.items()
                    if text
                },
            )
    except FileNotFoundError as exc:
        fail(str(exc))
    except ValueError as exc:
        fail(f"--sql {sql!r}: {exc}")
    if failed and not sql:
        table = table[table.status != "ok"]
        columns = "point,policy,status,error"
    if where:
        try:
            table = table.query(where)
        except Exception as exc:  # pandas raises many types for a bad expression
            fail(f"--where {where!r}: {exc}")
    names = [c.strip() for c in columns.split(",") if c.strip()]
    unknown = [c for c in names if c not in table.columns]
    if unknown and len(table.columns):
        fail(
            f"--columns: unknown column(s) {', '.join(unknown)}; see docs/results-and-metrics.md for the schema"
        )
    table = table[[c for c in names if c in table.columns]]
    if fmt == "csv":
        typer.echo(table.to_csv(index=False), nl=False)
    elif fmt == "json":
        typer.echo(table.to_json(orient="records"))
    elif fmt == "table":
        typer.echo(table.to_string(index=False) if len(table) else "(no runs match)")
    else:
        fail(f"--format {fmt!r}: expected table, csv or json")
