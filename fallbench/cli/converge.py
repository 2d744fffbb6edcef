"""`fallbench converge`: the same falls at smaller physics steps (or a later end), and whether
the headline metrics moved."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from fallbench.cli.common import PRE_IMPACT_HELP, _load, _matching, _policies, _strategies, fail
from fallbench.scenario import ScenarioError

if TYPE_CHECKING:
    import pandas as pd


def converge_command(
    file: Path = typer.Argument(..., help="Scenario YAML file."),
    point: list[str] = typer.Option(
        [], help="Sweep points: an index, or key=value (repeatable); default all."
    ),
    levels: int = typer.Option(3, min=2, max=6, help="Steps: physics_dt, /2, /4, ... (this many)."),
    policies: str = typer.Option("stiff,oneshot,zero,adaptive_qp", help="Comma-separated gain policies."),
    pre_impact: str = typer.Option("none", help=PRE_IMPACT_HELP),
    results: Path = typer.Option(Path("results"), help="Results store (the runs are ordinary runs)."),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="Parallel worker processes."),
    end: bool = typer.Option(
        False,
        "--end",
        help="Check the end instead of the step: each point as it is, with twice its cap and with twice its rest hold.",
    ),
) -> None:
    """Run the points at physics_dt, /2, /4, ... and print, per headline metric and policy, the value
    at each step and the relative change of the last halving.

    Exit 0 when every change is within 5 %; exit 1 otherwise (the table says which). With --end: exit 0
    when every run came to rest, twice the cap changed none of its metrics' bits, and twice the rest
    hold moved no headline metric by more than 5 %.
    """
    from fallbench.results.converge import convergence_table, end_ladder, end_table, ladder
    from fallbench.results.runner import expand, run_sweep

    chosen = _matching(_load([file]), point, file)
    if not chosen:
        fail(f"{file}: --point selects no point")
    try:
        ladders = [end_ladder(p) if end else ladder(p, levels) for p in chosen]
    except ScenarioError as exc:
        fail(str(exc))
    specs = expand(
        [rung for item in ladders for rung in item.levels], _policies(policies), _strategies(pre_impact)
    )
    runs = run_sweep(specs, results, jobs=jobs, progress=False)
    table = end_table(ladders, runs, specs) if end else convergence_table(ladders, runs, specs)
    if table.empty:
        fail(f"{file}: no run finished with status ok; see `fallbench results`")
    _echo_table(table)
    if end:
        _judge_end(table)
    else:
        _judge_step(table)


def _echo_table(table: pd.DataFrame) -> None:
    import pandas as pd

    with pd.option_context(
        "display.width", 200, "display.max_rows", None, "display.float_format", "{:.4g}".format
    ):
        typer.echo(table.to_string(index=False))


def _judge_end(table: pd.DataFrame) -> None:
    """Exit 1 unless every case settled and neither a longer cap nor a longer hold moved it."""
    from fallbench.results.converge import TOLERANCE

    off = table[~table["ok"]]
    if len(off):
        typer.echo(
            f"{len(off)} of {len(table)} cases did not settle, changed with twice the cap, or moved more "
            f"than {TOLERANCE:.0%} with twice the rest hold",
            err=True,
        )
        raise typer.Exit(1)
    typer.echo(f"the end decides nothing: {len(table)} cases settled, identical with twice the cap")


def _judge_step(table: pd.DataFrame) -> None:
    """Exit 1 if a headline metric moved more than the tolerance with the last halving."""
    from fallbench.results.converge import TOLERANCE

    off = table[~table["converged"]]
    if len(off):
        typer.echo(
            f"{len(off)} of {len(table)} (metric, case) pairs moved more than {TOLERANCE:.0%} with the last halving",
            err=True,
        )
        raise typer.Exit(1)
    typer.echo(f"converged: {len(table)} (metric, case) pairs within {TOLERANCE:.0%} of the previous step")
