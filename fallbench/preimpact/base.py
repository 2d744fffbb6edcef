"""The small interface every pre-impact strategy implements (what the robot does between fall
detection and impact).

The episode calls, in order: `start` once at fall detection; `step` every control step until every
motor has switched to the gain policy (a whole-fall controller, `hands_over = False`, never hands its
motors over: `step` is called every control step to the episode's end); `planned_contacts` every control step, so that a contact the
strategy meant to make (a footstep) is not taken for an impact; and after the episode `stats` (controller
figures) and `metrics` (outcome figures computed from the recording). Every call gets MuJoCo's
state; strategies read the robot description through `world.robot`, never a joint name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import mujoco

from fallbench.scenario import resolved_params
from fallbench.sim.servo import ServoCommand

if TYPE_CHECKING:
    from fallbench.scenario import Scenario
    from fallbench.sim.recorder import Recording
    from fallbench.sim.world import World


class Strategy(ABC):
    """One pre-impact strategy for one episode. Subclasses set `name` and `defaults`."""

    name: str = ""
    defaults: dict[str, Any] = {}  # parameters under `policy_params.<name>`, with their default values
    choices: dict[
        str, tuple[str, ...]
    ] = {}  # the allowed values of text parameters, checked when scenarios load
    # True: each motor switches to the gain policy when its own chain touches down (002 Sec. V);
    # False: every motor switches at the first impact.
    per_chain_switching: bool = False
    # True: the motors switch to the gain policy at impact (the papers' methods). False: a whole-fall
    # controller, which keeps every motor from fall detection to the episode's end (learned fall
    # policies); its runs carry no gain policy (`-`). Its control rate is its own: `step` is called
    # every control step and returns None between its own decisions.
    hands_over: bool = True
    # m the capture point must be outside the feet's support polygon for the strategy to start
    # (`detection.act_on`; docs/detection.md#false-alarms); None: the scenario's
    # `detection.capture_point_margin`, which declares the fall.
    start_margin: float | None = None
    # Parts of the robot description it cannot work without (RobotDescription field names): a robot
    # whose card leaves one out is refused when scenarios load, before any run.
    robot_needs: tuple[str, ...] = ()
    # Columns of its `stats` and `metrics` that every run's row carries, whichever strategy ran, with
    # the value of the runs it did not take part in (the registry collects them; other columns of
    # its own appear only in its runs' rows).
    stat_columns: dict[str, Any] = {}

    def __init__(self, world: World, scenario: Scenario) -> None:
        self.params = resolved_params(
            "strategy", self.name, self.defaults, scenario.policy_params.get(self.name, {})
        )
        self.world, self.scenario = world, scenario

    @classmethod
    def default_start_margin(cls) -> float | None:
        """m: `start_margin` at the strategy's default parameters (its `start_margin` parameter, if
        it has one); None: it starts when the scenario's detectors declare the fall."""
        return cls.defaults.get("start_margin", cls.start_margin)

    @classmethod
    def check(cls, scenario: Scenario) -> tuple[str, str] | None:
        """(key, reason) of the first problem of this strategy's parameters in `scenario` that their
        types cannot show (a model file that does not fit the robot), else None. Run when scenario
        files load, before any run."""
        return None

    @classmethod
    def inputs(cls, scenario: Scenario) -> dict[str, str]:
        """Files this strategy reads in `scenario` (path -> SHA-256 of the content): part of the
        run's identity, so that a changed file is a new run."""
        return {}

    @abstractmethod
    def start(self, t: float, data: mujoco.MjData) -> None:
        """At fall detection (t in s)."""

    @abstractmethod
    def step(self, t: float, data: mujoco.MjData) -> ServoCommand | None:
        """One control step after fall detection: the servo command, or None to keep the current one."""

    def planned_contacts(self) -> set[str]:
        """Robot bodies whose new contacts with the environment are planned (not impacts)."""
        return set()

    def stats(self) -> dict[str, Any]:
        """Per-episode controller figures (timings, failures) stored with the metrics."""
        return {}

    def metrics(self, recording: Recording) -> dict[str, Any]:
        """Per-episode outcome figures computed after the run from its recording."""
        return {}
