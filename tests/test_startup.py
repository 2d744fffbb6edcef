"""Start-up: the disk cache of compiled models gives the model a compile gives, and recovers from
a corrupt file; runs without a QP do not load Numba."""

from __future__ import annotations

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


def test_cached_model_simulates_bit_identically(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    scenario = Scenario(name="cache", duration=1.0, friction=0.9)
    compiled = world.compile_model(scenario)
    files = list((tmp_path / "fallbench").glob("world-*.mjb"))
    assert len(files) == 1
    loaded = world.compile_model(scenario)
    assert loaded.nq == compiled.nq and loaded.nsensor == compiled.nsensor
    np.testing.assert_array_equal(_steps(loaded), _steps(compiled))
    assert world.compile_model(scenario.model_copy(update={"friction": 0.8})) is not None
    assert len(list((tmp_path / "fallbench").glob("world-*.mjb"))) == 2  # another world, another file
    files[0].write_bytes(files[0].read_bytes()[:1000])  # truncated
    np.testing.assert_array_equal(_steps(world.compile_model(scenario)), _steps(compiled))
    assert world.compile_model(scenario).nq == compiled.nq  # rewritten whole


LOADS_NUMBA = """
import sys
from fallbench.registry import simulate_named
from fallbench.scenario import Scenario
simulate_named(Scenario(name="drop", duration=0.6, initial={{"height": 0.5}}), "{policy}")
print("numba" in sys.modules)
"""


@pytest.mark.parametrize("policy, loaded", [("stiff", "False"), ("zero", "False"), ("adaptive_qp", "True")])
def test_only_qp_runs_load_numba(policy: str, loaded: str) -> None:
    """Numba costs a process ~0.6 s to load (README): an episode through impact (impact metrics
    included) loads it only when a QP runs."""
    result = subprocess.run(
        [sys.executable, "-c", LOADS_NUMBA.format(policy=policy)], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip().splitlines()[-1] == loaded
