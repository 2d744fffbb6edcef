"""Nothing outside fallbench/robots/ names a particular robot: its joints, bodies, name or postures.

Code and string literals are scanned; docstrings and comments may cite where a number was measured."""

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


def _docstrings(tree: ast.AST) -> set[int]:
    nodes = [
        n
        for n in ast.walk(tree)
        if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
    ]
    return {id(n.body[0].value) for n in nodes if n.body and isinstance(n.body[0], ast.Expr)}


def _strings(tree: ast.AST) -> list[str]:
    """String literals (f-string parts included), docstrings left out."""
    skip = _docstrings(tree)
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip
    ]


def _identifiers(tree: ast.AST) -> list[str]:
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            names.append(node.id)
        elif isinstance(node, ast.Attribute):
            names.append(node.attr)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.arg):
            names.append(node.arg)
    return names


def test_the_scan_sees_every_module_and_would_catch_a_name() -> None:
    assert len(MODULES) > 20 and all("robots" not in p.parts[-2:-1] for p in MODULES)
    assert {"leg_right_4_joint", "right_knee_joint", "torso_2_link", "pelvis"} <= _robot_names()
    planted = ast.parse(
        '"""Measured on TALOS."""\nTALOS_KNEE = "leg_right_4_joint"\nGROUP = f"arm_{side}_link"'
    )
    assert _strings(planted) == ["leg_right_4_joint", "arm_", "_link"]
    assert "TALOS_KNEE" in _identifiers(planted)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_module_names_no_robot(path: Path) -> None:
    tree = ast.parse(path.read_text())
    literals = _strings(tree)
    tokens = {token for literal in literals for token in re.findall(r"[A-Za-z0-9_]+", literal)}
    assert not sorted(tokens & _robot_names()), (
        f"{path.name} names robot joints or bodies; add a field to the robot description"
    )
    for word in [*ROBOTS, "half_sitting", "half-sitting"]:
        assert not any(
            re.search(rf"(^|[^a-z0-9]){re.escape(word)}([^a-z0-9]|$)", text, re.IGNORECASE)
            for text in literals + _identifiers(tree)
        ), f"{path.name} names {word!r}"
