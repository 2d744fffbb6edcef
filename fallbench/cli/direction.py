"""`fallbench direction authority` and `direction radius`: 004's judge read from a results store."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from fallbench.cli.common import fail

if TYPE_CHECKING:
    import pandas as pd


direction_app = typer.Typer(help="004's direction-changing fall control: measurements.", no_args_is_help=True)


@direction_app.command("authority")
def direction_authority_command(
    results: Path = typer.Option(
        Path("results"), help="Results store with the runs of scenarios/direction_authority.yaml."
    ),
    out: Path | None = typer.Option(None, help="Also write the table to this CSV file."),
) -> None:
    """Steering authority in free space: per robot, push force and direction, the span of fall
    directions (deflection from `none`'s, deg) that the forced candidates of 004 reach.
    Run first: fallbench run sweep scenarios/direction_authority.yaml --pre-impact none,direction --policies stiff"""
    from fallbench.report.papers.direction_judge import authority_from_store

    table = _store_table(
        authority_from_store,
        results,
        f"{results}: no runs of scenarios/direction_authority.yaml (scenario dir_authority)",
    )
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(out, index=False)


@direction_app.command("radius")
def direction_radius_command(
    results: Path = typer.Option(
        Path("results"), help="Results store with `none` runs of scenarios/direction_bearing.yaml."
    ),
) -> None:
    """The robot radius of 004's grown circles, measured per robot from `none`'s falls past one object:
    the widest lateral offset of the object from the fall's line at which the fall still touched it.
    Run first: fallbench run sweep scenarios/direction_bearing.yaml --pre-impact none --policies stiff"""
    from fallbench.report.papers.direction_judge import radius_from_store

    _store_table(radius_from_store, results, f"{results}: no `none` falls past a single object")


def _store_table(make: Callable[[Path], pd.DataFrame], results: Path, empty: str) -> pd.DataFrame:
    """`make(results)` printed as Markdown; a missing store or an empty table is one error line, exit 2."""
    try:
        table = make(results)
    except FileNotFoundError as exc:
        fail(str(exc))
    if table.empty:
        fail(empty)
    typer.echo(table.to_markdown(index=False))
    return table
