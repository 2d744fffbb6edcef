"""Scenario files: schema, YAML loading with file:line errors, sweep expansion, content hash.

A scenario YAML describes a family of falls. `load_scenarios` validates it completely (schema,
sweep points, robot names, obstacles against the robot's start pose) before anything runs, and
`expand` turns it into one `RunSpec` per (sweep point, seed, policy, pre-impact strategy).

One module per job: `schema` (the fields and their ranges), `reading` (files, documents, checks),
`sweep` (sweep expansion into points), `sizes` (sizes that depend on the robot), `hashing` (content
hash). The names the rest of fallbench uses are re-exported here.
"""

from fallbench.scenario.hashing import canonical_json
from fallbench.scenario.reading import load_scenario_file, load_scenarios, points_with_seed, read_documents
from fallbench.scenario.schema import (
    DEFAULT_PHYSICS_DT,
    Box,
    Contact,
    Cylinder,
    Detection,
    Push,
    Scenario,
    ScenarioError,
    ScenarioFile,
    Timing,
    resolved_params,
)
from fallbench.scenario.sweep import ScenarioPoint

__all__ = [
    "DEFAULT_PHYSICS_DT",
    "Box",
    "Contact",
    "Cylinder",
    "Detection",
    "Push",
    "Scenario",
    "ScenarioError",
    "ScenarioFile",
    "ScenarioPoint",
    "Timing",
    "canonical_json",
    "load_scenario_file",
    "load_scenarios",
    "points_with_seed",
    "read_documents",
    "resolved_params",
]
