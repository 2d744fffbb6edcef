"""Whole commands in fresh interpreters, start-up included: `run sweep` with 1 and 2 jobs, `run one`,
the import time of what `run one` loads, `fallbench report` cold and warm."""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from fallbench.checks import load
from fallbench.scenario import DEFAULT_PHYSICS_DT, Scenario, ScenarioPoint


def _sweep_file(runs: int, folder: Path) -> Path:
    """A scenario file of runs / 4 points, drops and pushes in turn from the shipped files."""
    from ruamel.yaml import YAML

    shipped = Path(__file__).resolve().parents[2] / "scenarios"
    default = Scenario.model_fields["robot"].default  # the bench's sweep: one robot
    drops, pushes = (
        [
            p
            for p in load([shipped / name])
            if p.scenario.robot == default and p.scenario.physics_dt == DEFAULT_PHYSICS_DT
        ]
        for name in ("drop.yaml", "push.yaml")
    )
    mixed = [p for pair in zip(drops, pushes) for p in pair] + drops[len(pushes) :] + pushes[len(drops) :]
    if runs // 4 > len(mixed):
        raise ValueError(
            f"--e2e-runs {runs}: the shipped drops and pushes give at most {4 * len(mixed)} runs"
        )
    documents = [
        p.scenario.model_dump(mode="json", exclude_defaults=True) | {"name": f"{p.scenario.name}_{i}"}
        for i, p in enumerate(mixed[: runs // 4])
    ]
    path = folder / f"sweep{runs}.yaml"
    with open(path, "w") as handle:
        YAML(typ="safe", pure=True).dump_all(documents, handle)
    return path


def _command_s(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def _e2e_sweep_figures(
    cli: list[str],
    runs: int,
    folder: Path,
    sweep_repeats: int,
    progress: Callable[[str], None],
) -> dict[str, float]:
    """`run sweep` of `runs` shipped runs with 1 and 2 jobs in turn, `sweep_repeats` pairs: median
    wall times (s) and the median of the pairs' speedups."""
    path = _sweep_file(runs, folder)
    times: dict[int, list[float]] = {1: [], 2: []}
    for repeat in range(sweep_repeats):
        for jobs in (1, 2):
            progress(f"whole command: {runs}-run sweep, {jobs} job(s), pair {repeat + 1}/{sweep_repeats}")
            results = folder / f"r{runs}-{jobs}-{repeat}"
            times[jobs].append(
                _command_s(
                    cli
                    + [
                        "run",
                        "sweep",
                        str(path),
                        "--jobs",
                        str(jobs),
                        "--pre-impact",
                        "none",
                        "--results",
                        str(results),
                        "--reports",
                        str(results / "rep"),
                        "--no-progress",
                    ]
                )
            )
    figures = {f"e2e_sweep_s_{jobs}job_{runs}": statistics.median(times[jobs]) for jobs in (1, 2)}
    figures[f"e2e_speedup_{runs}"] = statistics.median(a / b for a, b in zip(times[1], times[2]))
    return figures


def _run_one_s(cli: list[str], point: ScenarioPoint, index: int, folder: Path, repeats: int) -> float:
    """Median wall time (s) of `run one` on the point (`index` in its file) with `stiff`, each into
    a fresh store."""
    return statistics.median(
        _command_s(
            cli
            + [
                "run",
                "one",
                point.source,
                "--point",
                str(index),
                "--policy",
                "stiff",
                "--results",
                str(folder / f"one{i}"),
            ]
        )
        for i in range(repeats)
    )


def _import_s(repeats: int) -> float:
    """Median time (s) a fresh interpreter takes to import the modules `run one` loads."""
    probe = (
        "import time; t = time.perf_counter(); import fallbench.cli, fallbench.results.runner, fallbench.sim.episode, "
        "fallbench.analysis.metrics; print(time.perf_counter() - t)"
    )
    return statistics.median(
        float(
            subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True).stdout
        )
        for _ in range(repeats)
    )


def command_figures(
    point: ScenarioPoint,
    runs_list: list[int],
    repeats: int,
    sweep_repeats: int,
    progress: Callable[[str], None],
) -> dict[str, float]:
    """Whole commands in fresh interpreters: sweeps with 1 and 2 jobs (in turn, `sweep_repeats`
    pairs, medians), `run one` on the point with `stiff`, and the import time of `run one`'s modules."""
    cli = [sys.executable, "-m", "fallbench.cli"]
    index = next(i for i, p in enumerate(load([point.source])) if p.label == point.label)
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        for runs in runs_list:
            figures.update(_e2e_sweep_figures(cli, runs, Path(folder), sweep_repeats, progress))
        progress("whole command: run one")
        figures["run_one_s"] = _run_one_s(cli, point, index, Path(folder), repeats)
    figures["import_s"] = _import_s(repeats)
    return figures


def report_figures(results: Path, jobs: int, progress: Callable[[str], None]) -> dict[str, float]:
    """`fallbench report` of the store `results` as a whole command (fresh interpreter, start-up
    included) with `jobs` drawing processes: cold into an empty folder, then warm into the same
    folder (every figure's runs unchanged, so none is drawn again)."""
    cli = [sys.executable, "-m", "fallbench.cli", "report", "--results", str(results), "--no-progress"]
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "report"
        command = cli + ["--out", str(out), "--jobs", str(jobs)]
        progress(f"report of {results}: cold")
        cold = _command_s(command)
        progress(f"report of {results}: warm")
        warm = _command_s(command)
        files = sum(1 for p in out.iterdir() if not p.name.startswith("."))
    return {"report_jobs": jobs, "report_cold_s": cold, "report_warm_s": warm, "report_files": files}
