"""Start-up: the disk cache of compiled models gives the model a compile gives, and recovers from
a corrupt file; runs without a QP do not load Numba."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import pytest

from fallbench.scenario import Scenario
from fallbench.sim import world


def _steps(model: mujoco.MjModel) -> np.ndarray:
    data = mujoco.MjData(model)
    data.qpos[2] += 0.3  # falling, then landing: contacts and limits at work
    for _ in range(400):
        mujoco.mj_step(model, data)
    return np.concatenate([data.qpos, data.qvel, data.sensordata])


def _fingerprint(data: bytes) -> tuple[int, str]:
    """Size and SHA-256 of a model file: a readable failure message for megabytes of bytes."""
    return len(data), hashlib.sha256(data).hexdigest()


def _serialized(model: mujoco.MjModel) -> tuple[int, str]:
    """The fingerprint of the model in MuJoCo's binary format: every size, option and array it holds."""
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return _fingerprint(buffer.tobytes())


def _not_compiled(scenario: Scenario) -> None:
    raise AssertionError(f"{scenario.name}: compiled again instead of read from the cache")


def test_cached_model_simulates_bit_identically(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(
        world, "_SCENES", {}
    )  # a new process: a scene an earlier test compiled holds its name
    cache = tmp_path / "fallbench"
    scenario = Scenario(name="cache", duration=1.0, friction=0.9, physics_dt=0.001)
    other = scenario.model_copy(update={"friction": 0.8, "physics_dt": 0.00025})
    direct = {s.friction: _serialized(world.build_spec(s).compile()) for s in (scenario, other)}
    compiled = world.compile_model(scenario)
    assert _serialized(compiled) == direct[0.9]  # the model a compile of the scenario gives, all of it
    [file] = list(cache.glob("world-*.mjb"))
    whole = file.read_bytes()
    with monkeypatch.context() as cached:
        cached.setattr(world, "build_spec", _not_compiled)
        cached.setattr(world, "_SCENES", {})  # a new process: read from the disk
        loaded = world.compile_model(scenario)
        # friction and step are set at run time: another friction and step share the file
        assert _serialized(world.compile_model(other)) == direct[0.8]
    assert _serialized(loaded) == direct[0.9]
    np.testing.assert_array_equal(_steps(loaded), _steps(compiled))
    assert list(cache.glob("world-*.mjb")) == [file]
    file.write_bytes(whole[:1000])  # truncated
    monkeypatch.setattr(world, "_SCENES", {})
    np.testing.assert_array_equal(_steps(world.compile_model(scenario)), _steps(compiled))
    assert _fingerprint(file.read_bytes()) == _fingerprint(whole)  # rewritten whole
    assert sorted(cache.iterdir()) == [file]  # no temporary file left behind


def test_model_cache_keeps_the_newest_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(world, "MODEL_CACHE_FILES", 2)
    cache = tmp_path / "fallbench"
    softnesses = (0.02, 0.03, 0.04)
    written: list[Path] = []  # each world's file, oldest first
    for index, softness in enumerate(softnesses):  # three worlds, three files
        before = set(cache.glob("world-*.mjb"))
        world.compile_model(Scenario(name="cache", duration=1.0, contact={"time_constant": softness}))
        [new] = set(cache.glob("world-*.mjb")) - before
        written.append(new)
        time.sleep(0.01)  # distinct modification times
        monkeypatch.setattr(world, "_SCENES", {})
        assert len(list(cache.glob("world-*.mjb"))) == min(index + 1, 2)
    assert sorted(cache.glob("world-*.mjb")) == sorted(written[1:])  # the oldest went, the newest two stayed
    with monkeypatch.context() as cached:  # ... and are read, not compiled again
        cached.setattr(world, "build_spec", _not_compiled)
        for softness in softnesses[1:]:
            world.compile_model(Scenario(name="cache", duration=1.0, contact={"time_constant": softness}))
            cached.setattr(world, "_SCENES", {})
        with pytest.raises(AssertionError, match="compiled again"):
            world.compile_model(Scenario(name="cache", duration=1.0, contact={"time_constant": 0.02}))


def test_a_run_owns_its_model_and_the_cached_scene_is_not_written() -> None:
    """A run's servo gains, friction and step go into its own model, never into the cached scene's."""
    scenario = Scenario(name="own", duration=1.0, friction=0.7, physics_dt=0.00025)
    scene = world.scene_world(scenario)
    gains = scene.model.actuator_gainprm.copy()
    run, other = world.build_world(scenario), world.build_world(scenario)
    assert run.model is not scene.model and run.model is not other.model
    assert run.model.opt.timestep == 0.00025 and (run.model.geom_friction[:, 0] == 0.7).all()
    run.model.actuator_gainprm[:, 0] *= 3.0  # as the run's servo writes them
    np.testing.assert_array_equal(scene.model.actuator_gainprm, gains)
    np.testing.assert_array_equal(other.model.actuator_gainprm, gains)
    assert scene.model.opt.timestep == world.RUNTIME_KEYS["physics_dt"]
    assert (scene.model.geom_friction[:, 0] == world.RUNTIME_KEYS["friction"]).all()


LOADS_NUMBA = """
import sys
from fallbench.assembly import simulate_named
from fallbench.scenario import Scenario
simulate_named(Scenario(name="drop", duration=0.6, initial={{"height": 0.5}}), "{policy}")
print("numba" in sys.modules)
"""


@pytest.mark.parametrize("policy, loaded", [("stiff", "False"), ("zero", "False"), ("adaptive_qp", "True")])
def test_only_qp_runs_load_numba(policy: str, loaded: str) -> None:
    """Numba costs a process ~0.6 s to load (docs/methods/adaptive_qp.md): an episode through impact (impact metrics
    included) loads it only when a QP runs."""
    result = subprocess.run(
        [sys.executable, "-c", LOADS_NUMBA.format(policy=policy)], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip().splitlines()[-1] == loaded
