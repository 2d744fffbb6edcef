from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from unittest import mock

import pytest

from fallbench.dynamics.model import PinocchioModel, build_pinocchio
from fallbench.scenario import Scenario
from fallbench.sim.world import World, build_world

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def world() -> World:
    """TALOS, the default robot, in the empty scene."""
    return build_world(Scenario(name="talos", duration=1.0))


@pytest.fixture(scope="session")
def robot(world: World) -> PinocchioModel:
    """TALOS's Pinocchio model, one for every test that needs it; a test computes what it reads on
    its data (no test relies on what another left there)."""
    return build_pinocchio(world)


@pytest.fixture
def drop_scenario() -> Scenario:
    return Scenario(name="drop", duration=1.0, initial={"height": 1.0})


# ---------------------------------------------------------------- `fallbench run sweep`


@dataclass(frozen=True)
class SweepResult:
    """One `fallbench run sweep` in this process: what the command printed, and the runs it
    simulated (the run ids handed to the backend; a resumed sweep hands over only missing runs)."""

    exit_code: int
    output: str  # stdout and stderr together
    stdout: str
    stderr: str
    exception: BaseException | None
    simulated: tuple[str, ...]


class Sweep:
    """`fallbench run sweep` on a scenario file (None: the shipped files) into a results store, its
    summary table in <results>/rep; fixed-gain policies without a pre-impact strategy, one job,
    unless told otherwise."""

    @staticmethod
    def arguments(
        suite: Path | None,
        results: Path,
        *options: str,
        policies: str = "stiff,zero",
        pre_impact: str = "none",
        jobs: int = 1,
    ) -> list[str]:
        return [
            "run",
            "sweep",
            *([str(suite)] if suite is not None else []),
            "--results",
            str(results),
            "--reports",
            str(results / "rep"),
            "--policies",
            policies,
            "--pre-impact",
            pre_impact,
            "--jobs",
            str(jobs),
            *options,
        ]

    def __call__(self, suite: Path | None, results: Path, *options: str, **choices) -> SweepResult:
        """Run the command in this process (typer's CliRunner), recording the runs it simulates."""
        from typer.testing import CliRunner

        from fallbench.cli import app
        from fallbench.results import runner

        simulated: list[str] = []
        run_and_store = runner.stored_rows

        def recorded(todo, *args, **kwargs):
            simulated.extend(spec.run_id for spec in todo)
            return run_and_store(todo, *args, **kwargs)

        with mock.patch.object(runner, "stored_rows", recorded):
            result = CliRunner().invoke(app, self.arguments(suite, results, *options, **choices))
        return SweepResult(
            result.exit_code, result.output, result.stdout, result.stderr, result.exception, tuple(simulated)
        )

    def command(self, suite: Path | None, results: Path, *options: str, **choices) -> list[str]:
        """The command line for a fresh Python process (no progress bar)."""
        return [
            sys.executable,
            "-m",
            "fallbench.cli",
            *self.arguments(suite, results, *options, **choices),
            "--no-progress",
        ]


@pytest.fixture(scope="session")
def sweep() -> Sweep:
    return Sweep()
