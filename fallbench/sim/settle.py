"""The robot standing in its `default` posture under the stiff servo, and the standing height of a
robot whose card leaves `standing_height` out.

The stance is the one `fallbench robots check` measures (fallbench/results/robot_check.py): the
robot in `default`, soles on the floor, its servos holding the posture with the card's stiff gains
for `STAND_TIME` s. A card without `standing_height` gets the root height the stance settles at,
derived once and kept in fallbench's cache folder (`$XDG_CACHE_HOME/fallbench`, beside the compiled
worlds) under the compiled stance scene's key (the card and model files, MuJoCo's and the model
package's versions, the source that builds the scene) and this module's source: a process reads it
from there, and a changed card, model or scene derives it again. `ensure_standing_height` puts it
into the robot's description, where sizes and metrics read it.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import mujoco

from fallbench.robots import get_robot
from fallbench.robots.cache import cache_root
from fallbench.robots.description import DEFAULT_POSTURE
from fallbench.scenario import Scenario
from fallbench.sim.world import RUNTIME_KEYS, build_world, initial_state, scene_digest

STAND_TIME = 2.0  # s standing under `stiff`


def stance_scenario(robot: str) -> Scenario:
    """The robot standing in `default`, feet on the floor, nothing else, for `STAND_TIME` s (the
    rest hold as long: the run does not end early at rest)."""
    return Scenario(name="stand", duration=STAND_TIME, robot=robot, rest={"hold": STAND_TIME})


def settled_height(robot: str) -> float:
    """m, the root's height after standing: the last state an episode of the stance records under
    `stiff` (at `STAND_TIME` less one physics step), reached by stepping the servos' constant hold."""
    scenario = stance_scenario(robot)
    world = build_world(scenario)
    data = initial_state(world, scenario)
    for _ in range(round(STAND_TIME / scenario.physics_dt) - 1):
        mujoco.mj_step(world.model, data)
    root = world.model.jnt_qposadr[world.model.body_jntadr[world.root_body]]
    return float(data.qpos[root + 2])


def standing_height_file(robot: str) -> Path:
    """Where the derived standing height of `robot` (a shipped name or a card path) is kept."""
    stance = stance_scenario(robot).model_copy(update=RUNTIME_KEYS)
    digest = hashlib.sha256(scene_digest(stance).encode() + Path(__file__).read_bytes()).hexdigest()
    return cache_root() / f"standing-{get_robot(robot).name}-{digest[:16]}.json"


def cached_standing_height(robot: str) -> float | None:
    """m, the derived standing height kept in the cache, else None (never derived, or unreadable)."""
    try:
        return float(json.loads(standing_height_file(robot).read_text())["standing_height"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _keep(path: Path, height: float) -> None:
    """Write atomically; a read-only or full cache only costs the next process a derivation."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".json.tmp")
        with os.fdopen(fd, "w") as stream:
            json.dump({"standing_height": height, "stand_time_s": STAND_TIME}, stream)
        os.replace(tmp, path)
    except OSError:
        pass


def ensure_standing_height(robot: str) -> float:
    """m, the robot's standing height: its card's, else the cached derivation, else derived now by
    settling (`settled_height`) and kept; put into the description's `default` height either way."""
    description = get_robot(robot)
    heights = description.posture_base_height
    if DEFAULT_POSTURE not in heights:
        height = cached_standing_height(robot)
        if height is None:
            height = settled_height(robot)
            _keep(standing_height_file(robot), height)
        heights[DEFAULT_POSTURE] = height
    return heights[DEFAULT_POSTURE]
