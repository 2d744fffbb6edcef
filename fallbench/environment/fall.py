"""`fallbench/Fall-v0`: one fall of a scenario file per episode, driven by a learned whole-fall
controller, through the same episode loop as `fallbench run` (`fallbench.sim.episode.Episode`:
the environment calls its `sense` and `act` halves itself and acts where the strategy decides).

- reset(seed): draws a point of the file's sweep and a fresh draw of its `randomize` ranges and
  posture noise (a new scenario seed from the environment's generator), then simulates up to the
  policy's first decision: fall detection (the robot stands under its stiff default servo before).
  A point whose fall is never detected is drawn again (up to `MAX_DRAWS` times).
- observation and action: `fallbench-obs-v1` (fallbench.preimpact.learned.observation), the same
  as the `onnx` strategy's, with its settings (`policy_params.onnx`: `control_dt`, `action_scale`).
- step(action): holds the action's joint targets for one `control_dt` of the policy (50 Hz by
  default) and returns the reward of the physics samples simulated meanwhile.
- reward: minus a weighted sum of fallbench's damage measures over the step (`DamageWeights`),
  and on the episode's last step a penalty if the robot ends it fallen (`DamageWeights.fell`,
  fallbench's own `fell` rule; 0 by default).
- `physics_dt` (s, optional) replaces every fall's physics step (a coarser step trains faster; the
  benchmark judges at the scenario's own step); `cap` (s, optional) replaces every fall's cap
  (`duration`), e.g. the benchmark's 10 s default so that training falls go on until the robot is
  at rest, as the benchmark's runs do.
- terminated when the robot has come to rest or the run diverged (the same rule as `fallbench run`,
  fallbench/sim/rest.py); truncated at the scenario's cap (`duration`) if it has not.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium
import mujoco
import numpy as np
from gymnasium import spaces

from fallbench.analysis.metrics import LIMIT_HIT_TOLERANCE, fell_height
from fallbench.assembly import run_world
from fallbench.checks import load
from fallbench.postimpact.stiff import StiffPolicy
from fallbench.preimpact.learned.onnx import OnnxStrategy
from fallbench.preimpact.learned.strategy import LearnedStrategy
from fallbench.scenario import Scenario, points_with_seed, read_documents
from fallbench.sim.episode import Episode, Sensed
from fallbench.sim.world import World

GRAVITY = 9.81  # m/s^2
MAX_DRAWS = 20  # falls drawn at a reset before giving up on a file whose falls are not detected


@dataclass(frozen=True)
class DamageWeights:
    """Weights of the reward, r = -(sum of weight x term) over one step's physics samples:

    - head, torso: peak net contact force on the robot's head / torso body group (body weights,
      m g; fallbench's `contact_force_peak_head`, `_torso`);
    - imu: peak accelerometer norm above 1 g (in g; 0 standing or falling freely; fallbench's
      `imu_peak_*`);
    - limit: joints past a limit stop (count; fallbench's `joint_limit_hits`);
    - torque: mean over samples and joints of (applied torque / limit)^2 (fallbench's
      `torque_ratio_max`, smoothed into an effort);
    - fell: 1 on the episode's last step (at rest, at the cap or diverged) if the robot ends it
      fallen by fallbench's `fell` rule (root below FELL_HEIGHT_FRACTION x its standing height in
      the scenario's posture; a diverged run counts as fallen), else 0: paid once per episode.
      0 by default, so the reward is the damage alone."""

    head: float = 1.0
    torso: float = 0.2
    imu: float = 0.05
    limit: float = 0.02
    torque: float = 0.1
    fell: float = 0.0


class EnvironmentStrategy(LearnedStrategy):
    """The whole-fall controller of the environment: the action is the agent's. It reads the
    `onnx` strategy's settings, so a model trained here runs there with the same ones."""

    name = OnnxStrategy.name
    defaults = OnnxStrategy.defaults

    def __init__(self, world: World, scenario: Scenario) -> None:
        super().__init__(world, scenario)
        self.action = np.zeros(self.layout.joints)

        self.seen: tuple[float, np.ndarray] | None = None  # (MuJoCo time s, observation) last computed

    def observe(self, data: mujoco.MjData) -> np.ndarray:
        """The observation, computed once per state (the agent's and the command's are one)."""
        if self.seen is None or self.seen[0] != data.time:
            self.seen = (data.time, super().observe(data))
        return self.seen[1]

    def decide(self, observation: np.ndarray) -> np.ndarray:
        return self.action


class DamageTerms:
    """The damage terms of a span of an episode's physics samples (see `DamageWeights`)."""

    def __init__(self, world: World) -> None:
        self.weight = float(world.model.body_subtreemass[world.root_body]) * GRAVITY
        # sensordata columns of the force (x, y, z) of each contact sensor of the group, sensor-major
        self.groups = [
            np.array(
                [
                    world.sensors[name].start + 1 + axis
                    for name in world.contact_groups.get(group, [])
                    for axis in range(3)
                ],
                dtype=int,
            )
            for group in ("head", "torso")
        ]
        imu = world.sensors["imu_acc"]
        self.imu = slice(imu.start, imu.start + imu.size)
        self.qpos_adr, self.joint_range, self.torque_limit = (
            world.qpos_adr,
            world.joint_range,
            world.torque_limit,
        )

    def group_peak(self, rows: np.ndarray, columns: np.ndarray) -> float:
        """Peak norm of the summed force (N) of one group's contact sensors, in body weights."""
        if not len(columns):
            return 0.0
        net = rows[:, columns].reshape(len(rows), -1, 3).sum(axis=1)
        return float(np.sqrt((net**2).sum(axis=1)).max()) / self.weight

    def of(self, episode: Episode, start: int, end: int) -> dict[str, float]:
        """The terms of samples [start, end) (a diverged run's NaNs count as 0)."""
        trace, clean = episode.trace, (lambda a: np.nan_to_num(a) if episode.status != "ok" else a)
        rows = clean(trace.sensordata[start:end])
        q = clean(trace.qpos[start:end, self.qpos_adr])
        margin = np.minimum(q - self.joint_range[:, 0], self.joint_range[:, 1] - q).min(axis=0)
        torque = clean(trace.actuator_force[start:end]) / self.torque_limit
        acc = np.sqrt((rows[:, self.imu] ** 2).sum(axis=1)).max() / GRAVITY
        return {
            "head": self.group_peak(rows, self.groups[0]),
            "torso": self.group_peak(rows, self.groups[1]),
            "imu": max(float(acc) - 1.0, 0.0),
            "limit": float(np.count_nonzero(margin < -LIMIT_HIT_TOLERANCE)),
            "torque": float((torque**2).mean()),
        }


class FallEnv(gymnasium.Env):
    """One fall of `scenario` (a scenario file) per episode (see the module docstring)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: str | Path,
        robot: str | None = None,
        reward_weights: dict[str, float] | DamageWeights | None = None,
        physics_dt: float | None = None,
        cap: float | None = None,
    ) -> None:
        self.path, self.robot = Path(scenario), robot
        points = load([self.path], robot)  # checks the whole file: ScenarioError on bad input
        robots = sorted({p.scenario.robot for p in points})
        if len(robots) != 1:
            raise ValueError(f"{self.path}: falls of several robots ({', '.join(robots)}); pass robot=")
        self.documents = read_documents(self.path)
        if physics_dt is not None:  # every fall's physics step (s), e.g. a coarser one for training
            for document in self.documents:
                document["physics_dt"] = physics_dt
        if cap is not None:  # every fall's cap (s), e.g. long enough for the robot to come to rest
            for document in self.documents:
                document["duration"] = cap
        if physics_dt is not None or cap is not None:
            points = points_with_seed(self.path, self.documents, 0, robot)  # checks the new settings
        self.weights = (
            reward_weights
            if isinstance(reward_weights, DamageWeights)
            else DamageWeights(**(reward_weights or {}))
        )
        world = run_world(points[0].scenario)
        self.terms = DamageTerms(world)
        joints = len(world.joint_names)
        size = EnvironmentStrategy(world, points[0].scenario).layout.size
        self.observation_space = spaces.Box(-np.inf, np.inf, (size,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (joints,), np.float32)
        self.episode: Episode | None = None
        self.strategy: EnvironmentStrategy | None = None
        self.pending: Sensed | None = None

    # ------------------------------------------------------------ driving the episode

    def _start(self, scenario: Scenario) -> None:
        world = run_world(scenario)
        self.strategy = EnvironmentStrategy(world, scenario)
        self.episode = Episode(
            world, scenario, StiffPolicy(world, scenario), self.strategy, self.strategy.name
        )

    def _to_decision(self) -> bool:
        """Simulate up to the strategy's next decision (True) or the episode's end (False)."""
        episode, strategy = self.episode, self.strategy
        assert episode is not None and strategy is not None
        while not episode.finished:
            sensed = episode.sense()
            if episode.strategy_steps_now() and strategy.due(sensed.t):
                self.pending = sensed
                return True
            episode.act(sensed)
        return False

    def _observation(self) -> np.ndarray:
        assert self.episode is not None and self.strategy is not None
        return np.nan_to_num(self.strategy.observe(self.episode.data), posinf=0.0, neginf=0.0)

    def _info(self) -> dict[str, Any]:
        assert self.episode is not None
        scenario = self.episode.scenario
        return {
            "t": self.episode.step * scenario.physics_dt,
            "seed": scenario.seed,
            "status": self.episode.status,
        }

    # ------------------------------------------------------------ Gymnasium API

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        for _ in range(MAX_DRAWS):
            draw = int(self.np_random.integers(0, 2**31))
            points = points_with_seed(self.path, self.documents, draw, self.robot)
            point = points[int(self.np_random.integers(len(points)))]
            self._start(point.scenario)
            if self._to_decision():
                return self._observation(), self._info() | {"point": point.label}
        raise RuntimeError(f"{self.path}: no fall detected in {MAX_DRAWS} draws")

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.pending is None or self.episode is None or self.strategy is None:
            raise RuntimeError("step() before reset() or after the episode's end")
        self.strategy.action = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        start = self.episode.step
        self.episode.act(self.pending)
        self.pending = None
        decided = self._to_decision()
        terms = self.terms.of(self.episode, start, self.episode.step)
        terms["fell"] = float(not decided and self._fallen())  # paid once, on the episode's last step
        reward = -sum(getattr(self.weights, key) * value for key, value in terms.items())
        capped = self.episode.capped  # the cap is a time limit (truncation), rest and divergence end the fall
        terminated = not decided and not capped
        return self._observation(), float(reward), terminated, capped, self._info() | {"damage": terms}

    def _fallen(self) -> bool:
        """Whether the robot ends the episode fallen, by fallbench's `fell` rule (metrics'
        `fell_height`, read on the last physics sample); a diverged run counts as fallen."""
        episode = self.episode
        assert episode is not None
        if episode.status != "ok":
            return True
        qpos = episode.trace.qpos
        height = float(qpos[episode.step - 1, 2])
        return not height >= fell_height(episode.world, episode.scenario, float(qpos[0, 2]))
