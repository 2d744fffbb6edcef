"""Strategies and gain policies from other installed packages, through Python entry points.

A package declares, in its pyproject.toml,

    [project.entry-points."fallbench.strategies"]
    my_strategy = "my_package.module:MyStrategy"

(or `fallbench.policies` for a gain policy); the name users type is the entry point's name.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any


def load_plugins(group: str, base: type, builtin: dict[str, Any]) -> dict[str, Any]:
    """name -> class of every entry point of `group`; a plugin may not replace a built-in name."""
    found: dict[str, Any] = {}
    for entry in entry_points(group=group):
        if entry.name in builtin:
            raise ValueError(f"entry point {entry.name!r} of {entry.value!r} ({group}) clashes with a built-in name")
        cls = entry.load()
        if not (isinstance(cls, type) and issubclass(cls, base)):
            raise TypeError(f"entry point {entry.name!r} ({group}) is {entry.value!r}, not a {base.__name__} subclass")
        found[entry.name] = cls
    return found
