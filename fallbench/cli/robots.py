"""`fallbench robots list`, `show` and `check`: the shipped cards, and whether a card can run the
benchmark."""

from __future__ import annotations

import typer

from fallbench.cli.common import _robot, fail
from fallbench.scenario import ScenarioError

robots_app = typer.Typer(
    help="Robots: the shipped cards, and whether a card can run the benchmark.", no_args_is_help=True
)


ROBOT_ARGUMENT = typer.Argument(..., help="A shipped robot's name, or a robot card file (*.yaml).")


@robots_app.command("list")
def robots_list_command() -> None:
    """The shipped robots: name, mass, standing height and card file."""
    from fallbench.robots import ROBOTS, get_robot

    for name, card in ROBOTS.items():
        robot = get_robot(name)
        typer.echo(f"{name:<10} {robot.mass:6.1f} kg  standing {robot.standing_height:.3f} m  {card}")


@robots_app.command("show")
def robots_show_command(robot: str = ROBOT_ARGUMENT) -> None:
    """What a robot's card gives: model files, bodies, postures, gains, body groups, legs, arms, feet."""
    from fallbench.results.robot_check import describe

    try:
        lines = describe(_robot(robot, "ROBOT") or "")
    except ScenarioError as exc:
        fail(str(exc))
    typer.echo("\n".join(lines))


@robots_app.command("check")
def robots_check_command(robot: str = ROBOT_ARGUMENT) -> None:
    """Compile the robot and check that it can run the benchmark: joint ranges and torque limits,
    body groups, no parts touching in its stance, standing still 2 s under `stiff` at its standing
    height, Pinocchio and MuJoCo agreeing.

    Exit 0 when it can; exit 1 with the reasons when it cannot; exit 2 on a bad card (one line).
    """
    from fallbench.results.robot_check import check_robot

    try:
        report = check_robot(_robot(robot, "ROBOT") or "")
    except ScenarioError as exc:
        fail(str(exc))
    typer.echo("\n".join(report.lines))
    if report.problems:
        for problem in report.problems:
            typer.echo(f"problem: {problem}", err=True)
        typer.echo(f"{robot} cannot run the benchmark ({len(report.problems)} problem(s))", err=True)
        raise typer.Exit(1)
    typer.echo(f"ok: {robot} can run the benchmark")
