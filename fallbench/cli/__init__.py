"""`fallbench` command line: parses, calls the library, formats errors. Bad input exits 2.

The typer app is assembled here from one module per command group: `run` (run sweep, run one),
`scenarios`, `robots`, `direction`, `converge`, `bench`, `check`, and `report` (report, render,
compare, results: the commands that read the store); `common` holds what they share.
"""

from __future__ import annotations

import typer

from fallbench.cli.bench import bench_command
from fallbench.cli.check import check_command
from fallbench.cli.converge import converge_command
from fallbench.cli.direction import direction_app
from fallbench.cli.report import compare_command, render_command, report_command, results_command
from fallbench.cli.robots import robots_app
from fallbench.cli.run import SHIPPED, run_app
from fallbench.cli.scenarios import scenarios_app

app = typer.Typer(
    help="Compare humanoid fall-control strategies in MuJoCo: sweep scenarios, store metrics.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(run_app, name="run")
app.add_typer(scenarios_app, name="scenarios")
app.add_typer(direction_app, name="direction")
app.add_typer(robots_app, name="robots")
app.command("converge")(converge_command)
app.command("bench")(bench_command)
app.command("report")(report_command)
app.command("render")(render_command)
app.command("compare")(compare_command)
app.command("results")(results_command)
app.command("check")(check_command)

__all__ = ["SHIPPED", "app", "main"]


def main() -> None:
    app()
