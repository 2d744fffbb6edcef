"""Start-up: the disk cache of compiled models gives the model a compile gives, and recovers from
a corrupt file; runs without a QP do not load Numba."""

from __future__ import annotations

import hashlib
import subprocess
import sys
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
    cache = tmp_path / "fallbench"
    scenario = Scenario(name="cache", duration=1.0, friction=0.9)
    compiled = world.compile_model(scenario)
    files = list(cache.glob("world-*.mjb"))
    assert len(files) == 1
    whole = files[0].read_bytes()
    assert _fingerprint(whole) == _serialized(compiled)  # the file holds the compiled model, all of it
    with monkeypatch.context() as cached:
        cached.setattr(world, "build_spec", _not_compiled)
        loaded = world.compile_model(scenario)
    assert _serialized(loaded) == _fingerprint(whole)
    np.testing.assert_array_equal(_steps(loaded), _steps(compiled))
    other = world.compile_model(scenario.model_copy(update={"friction": 0.8}))  # another world, another file
    np.testing.assert_array_equal(other.geom_friction[:, 0], 0.8)  # every geom: not the cached model
    np.testing.assert_array_equal(compiled.geom_friction[:, 0], 0.9)
    [other_file] = set(cache.glob("world-*.mjb")) - set(files)
    assert _fingerprint(other_file.read_bytes()) == _serialized(other)
    files[0].write_bytes(whole[:1000])  # truncated
    np.testing.assert_array_equal(_steps(world.compile_model(scenario)), _steps(compiled))
    assert _fingerprint(files[0].read_bytes()) == _fingerprint(whole)  # rewritten whole
    with monkeypatch.context() as cached:
        cached.setattr(world, "build_spec", _not_compiled)
        assert _serialized(world.compile_model(scenario)) == _fingerprint(whole)
    assert sorted(cache.iterdir()) == sorted([files[0], other_file])  # no temporary file left behind


LOADS_NUMBA = """
import sys
from fallbench.registry import simulate_named
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
