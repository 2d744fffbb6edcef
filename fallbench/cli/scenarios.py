"""`fallbench scenarios validate` and `fallbench scenarios export`: scenario files checked, a
point's scene written as MJCF."""

from __future__ import annotations

from pathlib import Path

import typer

from fallbench.cli.common import _load, _select

scenarios_app = typer.Typer(help="Check and export scenario files.", no_args_is_help=True)


@scenarios_app.command("validate")
def validate_command(files: list[Path] = typer.Argument(..., help="Scenario YAML files.")) -> None:
    """Check scenario files completely (schema, sweep points, robot, obstacles) without running them."""
    for file in files:
        points = _load([file])
        robots = sorted({p.scenario.robot for p in points})
        defaulted = any("robot" not in p.scenario.model_fields_set for p in points)
        typer.echo(
            f"{file}: ok, {len(points)} points, robot {', '.join(robots)}"
            + (" (default: no `robot` key)" if defaulted else "")
        )


@scenarios_app.command("export")
def export_command(
    file: Path = typer.Argument(..., help="Scenario YAML file."),
    point: list[str] = typer.Option([], help="Sweep point: an index, or key=value (repeatable)."),
    out: Path = typer.Option(Path("scene.xml"), help="MJCF file to write."),
) -> None:
    """Write the compiled scene (robot, floor, obstacles, actuators, sensors) as MJCF.

    The file opens in MuJoCo's viewer (`python -m mujoco.viewer --mjcf scene.xml`) and loads with
    `mujoco.MjModel.from_xml_path` alone; the keyframe `start` holds the initial state.
    """
    from fallbench.sim.world import export_mjcf

    chosen = _select(_load([file]), point or ["0"], file)
    out.write_text(export_mjcf(chosen.scenario))
    typer.echo(f"wrote {out} ({chosen.label})")
