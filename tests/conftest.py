from __future__ import annotations

from pathlib import Path

import pytest

from fallbench.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def drop_scenario() -> Scenario:
    return Scenario(name="drop", duration=1.0, initial={"height": 1.0})
