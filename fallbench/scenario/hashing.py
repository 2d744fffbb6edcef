"""A scenario's content hash, and the canonical JSON it and a run's identity are hashed from."""

from __future__ import annotations

import hashlib
import json
from typing import Any

from fallbench.scenario.schema import Scenario


def canonical_json(data: Any) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)


def scenario_hash(scenario: Scenario) -> str:
    return hashlib.sha256(canonical_json(scenario.model_dump(mode="json")).encode()).hexdigest()[:16]
