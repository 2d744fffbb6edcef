"""`fallbench` command line: parses, calls the library, formats errors. Bad input exits 2."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from fallbench.robots import DEFAULT_ROBOT
from fallbench.scenario import DEFAULT_PHYSICS_DT, ScenarioError, ScenarioPoint

if TYPE_CHECKING:
    import pandas as pd

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

app = typer.Typer(
    help="Compare humanoid fall-control strategies in MuJoCo: sweep scenarios, store metrics.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
run_app = typer.Typer(help="Simulate falls.", no_args_is_help=True)
scenarios_app = typer.Typer(help="Check and export scenario files.", no_args_is_help=True)
app.add_typer(run_app, name="run")
app.add_typer(scenarios_app, name="scenarios")
direction_app = typer.Typer(help="004's direction-changing fall control: measurements.", no_args_is_help=True)
app.add_typer(direction_app, name="direction")
robots_app = typer.Typer(
    help="Robots: the shipped cards, and whether a card can run the benchmark.", no_args_is_help=True
)
app.add_typer(robots_app, name="robots")

TIMESERIES_HELP = "How much of each run's time series to store: landing (every physics step about the first impact and each body group's first contact, 100 Hz elsewhere, quantised; ~55 KiB a run), full (every physics step, float32 as computed), none (metrics only: no replay or paper figures of the run)."


def fail(message: str, code: int = 2) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def _load(files: list[Path], robot: str | None = None) -> list[ScenarioPoint]:
    try:
        from fallbench.checks import load

        return load(list(files), robot)
    except ScenarioError as exc:
        fail(str(exc))
    raise AssertionError  # unreachable: fail() exits


def _names(text: str, known: Iterable[str], option: str, what: str) -> list[str]:
    """A comma-separated option's names, each checked against the known ones."""
    names = [p.strip() for p in text.split(",") if p.strip()]
    for name in names:
        if name not in known:
            fail(f"{option}: unknown {what} {name!r}; known: {', '.join(known)}")
    return names


def _policies(text: str) -> list[str]:
    from fallbench.registry import POLICIES

    return _names(text, POLICIES, "--policies", "policy")


def _robot(name: str | None, option: str = "--robot") -> str | None:
    """A robot option or argument: a shipped robot's name, or a robot card's path (from the
    current folder), made absolute."""
    from fallbench.robots import resolve_robot, robot_problem

    if name is None:
        return None
    robot = resolve_robot(name.strip(), Path.cwd())
    problem = robot_problem(robot)
    if problem:
        fail(f"{option}: {problem}")
    return robot


def _strategies(text: str) -> list[str]:
    from fallbench.registry import STRATEGIES

    return _names(text, STRATEGIES, "--pre-impact", "strategy")


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


PRE_IMPACT_HELP = "Comma-separated pre-impact strategies (none, reshape, direction, onnx, or a plugin's); a scenario's own `pre_impact` list wins. `onnx` (a learned whole-fall policy, `policy_params.onnx.model`) runs once per point with the policy `-`."


def _matching(points: list[ScenarioPoint], selectors: list[str], file: Path) -> list[ScenarioPoint]:
    """The points of a file's sweep that `--point 3` (index) or `--point key=value` (repeatable) select."""
    chosen = points
    for selector in selectors:
        if selector.isdigit():
            index = int(selector)
            if index >= len(points):
                fail(f"{file}: --point {index}: the file has {len(points)} points (0..{len(points) - 1})")
            chosen = [points[index]]
            continue
        key, _, value = selector.partition("=")
        if not value:
            fail(f"--point {selector!r}: expected an index or key=value")
        chosen = [
            p
            for p in chosen
            if (
                _same(p.swept[key], value)
                if key in p.swept
                else key == "robot" and _same(p.scenario.robot, value)
            )
        ]
    return chosen


def _select(points: list[ScenarioPoint], selectors: list[str], file: Path) -> ScenarioPoint:
    """Exactly one point of a file's sweep (see `_matching`)."""
    chosen = _matching(points, selectors, file)
    if len(chosen) != 1:
        labels = "\n  ".join(f"{i}: {p.label}" for i, p in enumerate(points))
        fail(f"{file}: --point selects {len(chosen)} points, need exactly 1; the points are:\n  {labels}")
    return chosen[0]


def _same(swept: object, text: str) -> bool:
    try:
        return abs(float(swept) - float(text)) < 1e-9  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(swept) == text


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
    keys = ["robot", "scenario", "pre_impact", "policy"]
    summary = table.groupby(keys)[SUMMARY_COLUMNS].median(numeric_only=True)
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


@app.command("converge")
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


@app.command("bench")
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

    from fallbench.results.bench import markdown, run_bench

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


@app.command("report")
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


@app.command("render")
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


@app.command("compare")
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


@app.command("results")
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


@app.command("check")
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
    from fallbench.report.direction_judge import authority_from_store

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
    from fallbench.report.direction_judge import radius_from_store

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


def main() -> None:
    app()


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


if __name__ == "__main__":
    main()
