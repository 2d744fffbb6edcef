from __future__ import annotations

from pathlib import Path

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
