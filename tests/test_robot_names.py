"""Nothing outside fallbench/robots/ names a particular robot: its joints, bodies, name or postures;
and no Python file at all names a robot's joint or body (robots are cards: fallbench/robots/cards/).

Code and string literals are scanned; docstrings and comments may cite where a number was measured."""

from __future__ import annotations

import ast
import re
import xml.etree.ElementTree as ET
from functools import cache
from pathlib import Path

import pytest

import fallbench
from fallbench.robots import ROBOTS, get_robot

PACKAGE = Path(fallbench.__file__).parent


def modules(package: Path) -> list[Path]:
    """The package's modules outside its robots/ folder, which alone may name a robot."""
    return sorted(p for p in package.rglob("*.py") if "robots" not in p.relative_to(package).parts)


MODULES = modules(PACKAGE)
ROBOT_MODULES = sorted((PACKAGE / "robots").rglob("*.py"))


# Link and joint names that are also fallbench's own words (Romeo's pelvis is `body`, its upper body
# `torso`, the joint between them `waist`): a literal "torso" is the body group, not Romeo's link
COMMON_WORDS = {"body", "torso", "waist"}


@cache
def _robot_names() -> frozenset[str]:
    """Every joint and link name of every shipped robot's URDF, but common words."""
    names: set[str] = set()
    for name in ROBOTS:
        root = ET.fromstring(get_robot(name).urdf_path.read_text())
        names |= {e.attrib["name"] for tag in ("joint", "link") for e in root.findall(tag)}
    return frozenset(names - COMMON_WORDS)


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


def robot_names_in(path: Path, robot_words: bool = True) -> list[str]:
    """What the module names of a robot: joint and body names in its string literals (split into
    words), and (with `robot_words`) robot or posture names in its literals and identifiers;
    docstrings are not read."""
    tree = ast.parse(path.read_text())
    literals = _strings(tree)
    tokens = {token for literal in literals for token in re.findall(r"[A-Za-z0-9_]+", literal)}
    found = sorted(tokens & _robot_names())
    for word in [*ROBOTS, "half_sitting", "half-sitting"] if robot_words else []:
        if any(
            re.search(rf"(^|[^a-z0-9]){re.escape(word)}([^a-z0-9]|$)", text, re.IGNORECASE)
            for text in literals + _identifiers(tree)
        ):
            found.append(word)
    return found


def test_the_scan_sees_every_module_and_would_catch_a_name(tmp_path: Path) -> None:
    assert len(MODULES) > 20 and all("robots" not in p.parts[-2:-1] for p in MODULES)
    assert {"leg_right_4_joint", "right_knee_joint", "torso_2_link", "pelvis"} <= _robot_names()
    planted = {
        "robots/talos.py": 'KNEE = "leg_right_4_joint"\n',  # the one place a robot may be named
        "clean.py": '"""Measured on TALOS (leg_right_4_joint)."""\nKNEE = robot.knee_joint\n',
        "deep/knee.py": 'KNEES = {"right": "leg_right_4_joint", "left": "leg_left_4_joint"}\n',
        "deep/limit.py": 'MARGIN = f"{margin:.2f} rad at torso_2_link"\n',
        "pose.py": 'def start(world):\n    return world.postures["half_sitting"]\n',
        "names.py": "TALOS_MASS = 99.0\n",
    }
    for name, source in planted.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(source)
    found = {str(p.relative_to(tmp_path)): robot_names_in(p) for p in modules(tmp_path)}
    assert found == {
        "clean.py": [],  # docstrings may cite where a number was measured
        "deep/knee.py": ["leg_left_4_joint", "leg_right_4_joint"],
        "deep/limit.py": ["torso_2_link"],  # inside an f-string's text
        "pose.py": ["half_sitting"],
        "names.py": ["talos"],  # in an identifier
    }


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_module_names_no_robot(path: Path) -> None:
    assert robot_names_in(path) == [], f"{path.name} names a robot; add a field to the robot description"


@pytest.mark.parametrize("path", ROBOT_MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_robot_layer_names_no_joint_or_body(path: Path) -> None:
    """The robot layer reads cards: a joint or body name belongs in a card, not in Python."""
    assert robot_names_in(path, robot_words=False) == [], (
        f"{path.name} names a joint or body; put it in a card"
    )
