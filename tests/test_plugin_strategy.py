"""A new strategy that needs the outcome among objects and declares its own stat columns is one
file plus its registry line: `HeadingProbe` below, registered by one line in the test, runs a
short episode among objects through the sweep runner, and its columns and the obstacle outcome
land in the metrics row; every other run's row gets its columns' declared defaults."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import pytest

from fallbench.analysis.obstacles import actual_fall_direction_deg, direction_error_deg
from fallbench.checks import check_controllers
from fallbench.preimpact.base import Strategy
from fallbench.registry import STRATEGIES, stat_columns
from fallbench.results.runner import RunSpec, simulate
from fallbench.scenario import Scenario, ScenarioPoint
from fallbench.sim.recorder import Recording
from fallbench.sim.servo import ServoCommand
from fallbench.sim.world import World


class HeadingProbe(Strategy):
    """Holds the starting references until impact (as `none`), counts its control steps, and reports
    how far the actual fall direction (the outcome among objects) lies from the push's."""

    name = "heading_probe"
    stat_columns = {"probe_heading_error_deg": math.nan, "probe_steps": 0}

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.steps = 0

    def start(self, t: float, data: mujoco.MjData) -> None:
        pass

    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        self.steps += 1
        return None

    def stats(self) -> dict[str, Any]:
        return {"probe_steps": self.steps}

    def metrics(self, recording: Recording) -> dict[str, Any]:
        push = recording.scenario.push
        actual = actual_fall_direction_deg(recording, recording.fall_time)
        return {"probe_heading_error_deg": direction_error_deg(push.direction if push else 0.0, actual)}


AMONG_OBJECTS = Scenario(  # 004's table ahead and a person to the left; a push forward
    name="probe",
    duration=0.6,
    push={"force": 384, "duration": 0.1, "start": 0.1, "direction": 0},
    obstacles=[
        {"type": "box", "pos": [1.25, 0.0, 0.375], "size": [0.6, 0.6, 0.75]},
        {"type": "cylinder", "pos": [-0.113, 1.295, 0.85], "radius": 0.25, "height": 1.7},
    ],
)


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(STRATEGIES, HeadingProbe.name, HeadingProbe)  # the registry line


def _row(pre_impact: str) -> dict[str, Any]:
    """The metrics row of one run among the objects, as a sweep computes it."""
    spec = RunSpec(ScenarioPoint(AMONG_OBJECTS, {}, "test"), "stiff", pre_impact)
    outcome = simulate(spec, keep_series=False)
    assert outcome.row["status"] == "ok", outcome.row["error"]
    return outcome.row


def test_a_plugin_strategy_gets_its_columns_and_the_obstacle_outcome(registered: None) -> None:
    assert check_controllers(AMONG_OBJECTS.model_copy(update={"pre_impact": (HeadingProbe.name,)})) is None
    assert stat_columns()["probe_steps"] == 0  # collected with the built-in ones
    row = _row(HeadingProbe.name)
    assert row["pre_impact"] == HeadingProbe.name and row["probe_steps"] > 0
    # the outcome among objects is in the row, and the probe read the same fall direction
    assert row["n_safe_regions"] >= 1 and isinstance(row["obstacle_hit"], bool)
    assert row["probe_heading_error_deg"] == pytest.approx(
        direction_error_deg(0.0, row["actual_fall_direction_deg"])
    )
    assert row["probe_heading_error_deg"] < 10.0  # deg: the fall goes the push's way
    other = _row("none")  # another strategy's row carries the probe's declared defaults
    assert math.isnan(other["probe_heading_error_deg"]) and other["probe_steps"] == 0
    assert other["actual_fall_direction_deg"] == pytest.approx(row["actual_fall_direction_deg"], abs=1e-9)
