"""`fallbench run sweep` and `fallbench run one`: simulate falls into the results store."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import typer

from fallbench.cli.common import PRE_IMPACT_HELP, _load, _policies, _robot, _select, _strategies, fail
from fallbench.scenario import ScenarioPoint

SHIPPED = [
    Path("scenarios/drop.yaml"),
    Path("scenarios/push.yaml"),
    Path("scenarios/obstacles.yaml"),
    Path("scenarios/clutter.yaml"),
    Path("scenarios/direction.yaml"),
    Path("scenarios/random.yaml"),
]


SUMMARY_COLUMNS = [
    "imu_peak_z",
    "knee_limit_margin",
    "torque_ratio_max",
    "torque_demand_ratio_max",
    "joint_limit_hits",
    "contact_force_peak",
    "contact_force_peak_head",
    "contact_force_peak_torso",
    "first_impact_safe",
    "landing_error",
    "fell",
]


run_app = typer.Typer(help="Simulate falls.", no_args_is_help=True)


TIMESERIES_HELP = "How much of each run's time series to store: landing (every physics step about the first impact and each body group's first contact, 100 Hz elsewhere, quantised; ~55 KiB a run), full (every physics step, float32 as computed), none (metrics only: no replay or paper figures of the run)."


def _with_params(points: list[ScenarioPoint], settings: list[str]) -> list[ScenarioPoint]:
    """The points with `--policy-param NAME.KEY=VALUE` settings (YAML values) in their
    `policy_params`, checked as if the files had said so."""
    import dataclasses

    from ruamel.yaml import YAML

    from fallbench.checks import check_controllers
    from fallbench.scenario import Scenario

    if not settings:
        return points
    overrides: dict[str, dict[str, object]] = {}
    for setting in settings:
        dotted, _, text = setting.partition("=")
        name, _, key = dotted.partition(".")
        if not (name and key and text):
            fail(f"--policy-param {setting!r}: expected NAME.KEY=VALUE, e.g. onnx.model=policy.onnx")
        overrides.setdefault(name, {})[key] = YAML(typ="safe").load(text)
    changed = []
    for point in points:
        params = {name: dict(values) for name, values in point.scenario.policy_params.items()}
        for name, values in overrides.items():
            params[name] = params.get(name, {}) | values
        try:
            scenario = Scenario.model_validate(point.scenario.model_dump() | {"policy_params": params})
        except ValueError as exc:
            fail(f"--policy-param: {' '.join(str(exc).split())}")
        problem = check_controllers(scenario)
        if problem:
            fail(f"{point.source}: --policy-param: {problem[0]}: {problem[1]}")
        changed.append(dataclasses.replace(point, scenario=scenario))
    return changed


def _check_strategies(points: list[ScenarioPoint], strategies: list[str]) -> None:
    """The strategies' own checks (an ONNX model that must fit the robot) on every point they will
    run on, before any run: one `error:` line and exit 2 on the first problem."""
    from fallbench.checks import check_strategies

    checked: set[tuple[str, str]] = set()
    for point in points:
        names = point.scenario.pre_impact or strategies
        key = (point.scenario.model_copy(update={"seed": 0}).model_dump_json(), ",".join(names))
        if key in checked:
            continue
        checked.add(key)
        problem = check_strategies(point.scenario, names)
        if problem:
            fail(f"{point.source}: {problem[0]}: {problem[1]}")


@run_app.command("sweep")
def run_sweep_command(
    files: list[Path] = typer.Argument(
        None,
        help="Scenario YAML files (default: the shipped drop, push, obstacle, clutter, direction and randomised scenarios).",
    ),
    policies: str = typer.Option("stiff,oneshot,zero,adaptive_qp", help="Comma-separated gain policies."),
    pre_impact: str = typer.Option("none,reshape", help=PRE_IMPACT_HELP),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="Parallel worker processes (see --backend)."),
    backend: str = typer.Option(
        "auto",
        help="auto: this process for one job or one run, else fork; fork: workers forked from this process (they start with its imports and compiled worlds); loky: fresh processes on this machine; dask: a Dask cluster (needs fallbench's optional `dask` extra).",
    ),
    scheduler: str = typer.Option(
        None,
        help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (default: a LocalCluster of --jobs workers).",
    ),
    results: Path = typer.Option(Path("results"), help="Results store folder."),
    reports: Path = typer.Option(Path("reports"), help="Folder for the sweep summary table."),
    strict: bool = typer.Option(False, help="Exit 1 at the end if any run failed or diverged."),
    progress: bool = typer.Option(True, help="Show a progress bar."),
    robot: str | None = typer.Option(
        None,
        help="Run every file on this robot (a shipped name, or a robot card file), replacing the files' `robot` and any sweep over robots (sizes scale, see docs/scenarios.md).",
    ),
    policy_param: list[str] = typer.Option(
        [],
        "--policy-param",
        help="NAME.KEY=VALUE (repeatable): a controller parameter set in every point's `policy_params`, e.g. onnx.model=my_policy.onnx.",
    ),
    timeseries: str = typer.Option(
        "landing",
        help=TIMESERIES_HELP,
    ),
) -> None:
    """Run every (scenario point, seed, pre-impact strategy, policy) not yet in the store, then print a summary.

    Interrupted sweeps resume: finished runs are skipped. Failed runs are stored with their status.
    Workers only simulate; this process writes the store, so Dask workers need no shared disk.
    """
    from fallbench.results.runner import expand, run_sweep

    _check_backend(backend, scheduler)
    _check_timeseries(timeseries)
    points = _with_params(_load(files or SHIPPED, _robot(robot)), policy_param)
    strategies = _strategies(pre_impact)
    _check_strategies(points, strategies)
    specs = expand(points, _policies(policies), strategies)
    table = run_sweep(
        specs,
        results,
        jobs=jobs,
        progress=progress and sys.stderr.isatty(),
        backend=backend,
        scheduler=scheduler,
        timeseries=timeseries,
    )
    typer.echo(_sweep_summary(table, reports).round(3).to_string())
    failed = table[table.status != "ok"]
    typer.echo(
        f"\n{len(table)} runs in {results}/metrics/, {len(failed)} failed or diverged; summary in {reports}/sweep_summary.md"
    )
    for _, row in failed.iterrows():
        typer.echo(f"  {row.status}: {row.pre_impact}/{row.policy} {row.point}: {row.error}", err=True)
    if strict and len(failed):
        raise typer.Exit(1)


def _check_timeseries(mode: str) -> None:
    from fallbench.results.series import TIMESERIES_MODES

    if mode not in TIMESERIES_MODES:
        fail(f"--timeseries: unknown mode {mode!r}; known: {', '.join(TIMESERIES_MODES)}")


def _check_backend(backend: str, scheduler: str | None) -> None:
    from fallbench.results.runner import BACKENDS

    if backend not in BACKENDS:
        fail(f"--backend: unknown backend {backend!r}; known: {', '.join(BACKENDS)}")
    if scheduler and backend != "dask":
        fail("--scheduler needs --backend dask")
    if backend == "dask" and importlib.util.find_spec("distributed") is None:
        fail("--backend dask needs Dask's distributed scheduler: pip install 'fallbench[dask]'")


def _sweep_summary(table, reports: Path):
    """Medians per (robot, scenario, strategy, policy) with run and failure counts, also written to
    `reports/sweep_summary.md`."""
    from fallbench.robots import robot_names  # a card's robot by its name, as the report names it

    table = table.assign(robot=table.robot.map(robot_names(list(table.robot.unique()))))
    keys = ["robot", "scenario", "pre_impact", "policy"]
    measured = [column for column in SUMMARY_COLUMNS if column in table]  # none if every run failed
    summary = table.groupby(keys)[measured].median(numeric_only=True)
    summary.insert(0, "runs", table.groupby(keys).size())
    summary.insert(
        1, "failed", table[table.status != "ok"].groupby(keys).size().reindex(summary.index, fill_value=0)
    )
    reports.mkdir(parents=True, exist_ok=True)
    (reports / "sweep_summary.md").write_text(
        "# Sweep summary (medians over runs)\n\n" + summary.round(3).to_markdown() + "\n"
    )
    return summary


@run_app.command("one")
def run_one_command(
    file: Path = typer.Argument(..., help="Scenario YAML file."),
    point: list[str] = typer.Option([], help="Sweep point: an index, or key=value (repeatable)."),
    policy: str = typer.Option("stiff", help="Gain policy."),
    pre_impact: str = typer.Option(
        "none", help="Pre-impact strategy (none, reshape, direction, or a plugin's)."
    ),
    results: Path = typer.Option(Path("results"), help="Results store folder."),
    timeseries: str = typer.Option(
        "landing",
        help=TIMESERIES_HELP,
    ),
) -> None:
    """Run one case, store it, and print its metrics."""
    from fallbench.registry import run_policy
    from fallbench.results.runner import RunSpec, execute

    _check_timeseries(timeseries)
    chosen = _select(_load([file]), point, file)
    strategy = _strategies(pre_impact)[0]
    _check_strategies([chosen], [strategy])
    row = execute(RunSpec(chosen, run_policy(strategy, _policies(policy)[0]), strategy), results, timeseries)
    width = max(len(k) for k in row)
    for key, value in row.items():
        typer.echo(f"{key:<{width}}  {value:.4g}" if isinstance(value, float) else f"{key:<{width}}  {value}")
    if row["status"] != "ok":
        raise typer.Exit(1)
