"""Strategies and gain policies from other installed packages, through Python entry points.

A package declares, in its pyproject.toml,

    [project.entry-points."fallbench.strategies"]
    my_strategy = "my_package.module:MyStrategy"

(or `fallbench.policies` for a gain policy); the name users type is the entry point's name.
Entry points are loaded on the registry's first use, not at import, so that a plug-in may import
fallbench's own modules (its base classes) without a circular import.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any, Iterator


def resolved_params(kind: str, name: str, defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """A policy's or strategy's parameters: its defaults overridden by the scenario's (no unknown ones)."""
    unknown = set(given) - set(defaults)
    if unknown:
        raise ValueError(f"{kind} {name!r}: unknown parameter(s) {', '.join(sorted(unknown))}; "
                         f"known: {', '.join(sorted(defaults)) or 'none'}")
    return {**defaults, **given}


class Registry(dict):
    """name -> class: the built-in ones, then the entry points of `group` on first use."""

    def __init__(self, group: str, base: type, builtin: dict[str, Any], kind: str) -> None:
        super().__init__(builtin)
        self.group, self.base, self.kind, self.loaded = group, base, kind, False

    def create(self, name: str, *args: Any) -> Any:
        """An instance of the class registered as `name`."""
        if name not in self:
            raise ValueError(f"unknown {self.kind} {name!r}; known: {', '.join(self)}")
        return self[name](*args)

    def _load(self) -> None:
        if self.loaded:
            return
        self.loaded = True
        for entry in entry_points(group=self.group):
            if dict.__contains__(self, entry.name):
                raise ValueError(f"entry point {entry.name!r} = {entry.value!r} ({self.group}) clashes with a built-in name")
            cls = entry.load()
            if not (isinstance(cls, type) and issubclass(cls, self.base)):
                raise TypeError(f"entry point {entry.name!r} = {entry.value!r} ({self.group}) is not a {self.base.__name__} subclass")
            dict.__setitem__(self, entry.name, cls)

    def __getitem__(self, name: str) -> Any:
        self._load()
        return dict.__getitem__(self, name)

    def __contains__(self, name: object) -> bool:
        self._load()
        return dict.__contains__(self, name)

    def __iter__(self) -> Iterator[str]:
        self._load()
        return dict.__iter__(self)

    def __len__(self) -> int:
        self._load()
        return dict.__len__(self)

    def get(self, name: str, default: Any = None) -> Any:
        self._load()
        return dict.get(self, name, default)

    def keys(self):  # type: ignore[override]
        self._load()
        return dict.keys(self)

    def values(self):  # type: ignore[override]
        self._load()
        return dict.values(self)

    def items(self):  # type: ignore[override]
        self._load()
        return dict.items(self)
