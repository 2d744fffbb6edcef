"""Nothing outside fallbench/robots/ names a particular robot: its joints, bodies, name or postures."""

from __future__ import annotations

import ast
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import fallbench
from fallbench.robots import ROBOTS, get_robot

PACKAGE = Path(fallbench.__file__).parent
MODULES = sorted(p for p in PACKAGE.rglob("*.py") if "robots" not in p.relative_to(PACKAGE).parts)


def _robot_names() -> set[str]:
    """Every joint and link name of every registered robot's URDF."""
    names: set[str] = set()
    for name in ROBOTS:
        root = ET.fromstring(get_robot(name).urdf_path.read_text())
        names |= {e.attrib["name"] for tag in ("joint", "link") for e in root.findall(tag)}
    return names


def _strings(tree: ast.AST) -> list[str]:
    return [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)]


def test_the_scan_sees_every_module_and_would_catch_a_name() -> None:
    assert len(MODULES) > 20 and all("robots" not in p.parts[-2:-1] for p in MODULES)
    assert {"leg_right_4_joint", "right_knee_joint", "torso_2_link", "pelvis"} <= _robot_names()
    planted = ast.parse('KNEE = "leg_right_4_joint"\nGROUP = f"arm_{side}_link"')
    assert "leg_right_4_joint" in _strings(planted)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_module_names_no_robot(path: Path) -> None:
    text = path.read_text()
    names = _robot_names()
    tokens = {token for literal in _strings(ast.parse(text)) for token in re.findall(r"[A-Za-z0-9_]+", literal)}
    assert not sorted(tokens & names), f"{path.name} names robot joints or bodies; add a field to the robot description"
    for word in [*ROBOTS, "half_sitting", "half-sitting"]:
        assert not re.search(rf"\b{re.escape(word)}\b", text, re.IGNORECASE), f"{path.name} mentions {word!r}"
