"""The plug-in registry: every pre-impact strategy and post-impact gain policy by the name users
type, and the stat columns they declare.

A new built-in is a new file plus a line in `BUILTIN_POLICIES` or `BUILTIN_STRATEGIES` (robots:
`fallbench.robots`). Other installed packages add their own through Python entry points: a package
declares, in its pyproject.toml,

    [project.entry-points."fallbench.strategies"]
    my_strategy = "my_package.module:MyStrategy"

(or `fallbench.policies` for a gain policy); the name users type is the entry point's name.
Entry points are loaded on the registry's first use (`policies()`, `strategies()`, `load_policy`,
`load_strategy`, or reading `POLICIES` / `STRATEGIES`), not at import, so that a plug-in may
import fallbench's own modules (its base classes) without a circular import.

The scenario checks that need the registered controllers are `fallbench.checks`; a run put
together from the registered names is `fallbench.assembly`.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any, TypeVar

from fallbench.postimpact.adaptive_qp.policy import AdaptiveQPPolicy
from fallbench.postimpact.adaptive_qp_hold import AdaptiveQPHoldPolicy
from fallbench.postimpact.base import GainPolicy
from fallbench.postimpact.oneshot import OneshotPolicy
from fallbench.postimpact.stiff import StiffPolicy
from fallbench.postimpact.zero import ZeroPolicy
from fallbench.preimpact.base import Strategy
from fallbench.preimpact.direction.strategy import DirectionStrategy
from fallbench.preimpact.learned.onnx import OnnxStrategy
from fallbench.preimpact.none import NoStrategy
from fallbench.preimpact.reshape.strategy import ReshapeStrategy

BUILTIN_POLICIES: dict[str, type[GainPolicy]] = {
    "stiff": StiffPolicy,
    "oneshot": OneshotPolicy,
    "zero": ZeroPolicy,
    "adaptive_qp": AdaptiveQPPolicy,
    "adaptive_qp_hold": AdaptiveQPHoldPolicy,
}
BUILTIN_STRATEGIES: dict[str, type[Strategy]] = {
    "none": NoStrategy,
    "reshape": ReshapeStrategy,
    "direction": DirectionStrategy,
    "onnx": OnnxStrategy,
}
POLICY_GROUP, STRATEGY_GROUP = "fallbench.policies", "fallbench.strategies"  # entry-point groups
NO_POLICY = "-"  # the policy of a whole-fall controller's runs: it never hands its motors over

# name -> class, the built-in ones and then the entry points, filled on first use
_policies: dict[str, type[GainPolicy]] = {}
_strategies: dict[str, type[Strategy]] = {}

Controller = TypeVar("Controller", GainPolicy, Strategy)


def policies() -> dict[str, type[GainPolicy]]:
    """Every gain policy by name: the built-in ones, then the entry points `fallbench.policies`."""
    if not _policies:
        _policies.update(_with_entry_points(BUILTIN_POLICIES, POLICY_GROUP, GainPolicy))
    return _policies


def strategies() -> dict[str, type[Strategy]]:
    """Every pre-impact strategy by name: the built-in ones, then the entry points
    `fallbench.strategies`."""
    if not _strategies:
        _strategies.update(_with_entry_points(BUILTIN_STRATEGIES, STRATEGY_GROUP, Strategy))
    return _strategies


def __getattr__(name: str) -> Any:
    """`POLICIES` and `STRATEGIES`: `policies()` and `strategies()` (the same dicts), read as names."""
    if name == "POLICIES":
        return policies()
    if name == "STRATEGIES":
        return strategies()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def load_policy(name: str) -> type[GainPolicy]:
    """The gain policy registered as `name` (ValueError if none is)."""
    return _lookup(policies(), name, "policy")


def load_strategy(name: str) -> type[Strategy]:
    """The pre-impact strategy registered as `name` (ValueError if none is)."""
    return _lookup(strategies(), name, "pre-impact strategy")


def _lookup(registered: dict[str, type[Controller]], name: str, kind: str) -> type[Controller]:
    if name not in registered:
        raise ValueError(f"unknown {kind} {name!r}; known: {', '.join(registered)}")
    return registered[name]


def _with_entry_points(
    builtin: dict[str, type[Controller]], group: str, base: type[Controller]
) -> dict[str, type[Controller]]:
    """The built-in classes, then the entry points of `group`: each must be a `base` subclass under
    a name of its own."""
    found = dict(builtin)
    for entry in entry_points(group=group):
        if entry.name in found:
            raise ValueError(
                f"entry point {entry.name!r} = {entry.value!r} ({group}) clashes with a built-in name"
            )
        cls = entry.load()
        if not (isinstance(cls, type) and issubclass(cls, base)):
            raise TypeError(
                f"entry point {entry.name!r} = {entry.value!r} ({group}) is not a {base.__name__} subclass"
            )
        found[entry.name] = cls
    return found


def run_policy(pre_impact: str, policy: str) -> str:
    """The gain policy a run of `pre_impact` carries: `policy`, or `-` for a whole-fall controller."""
    strategy = strategies().get(pre_impact)
    return NO_POLICY if strategy is not None and not strategy.hands_over else policy


def stat_columns() -> dict[str, Any]:
    """The columns every run's row has, whichever controllers ran: each registered policy's and
    strategy's `stat_columns`, in registration order, with the value of the runs it did not take
    part in. Two that declare one column must agree on its value."""
    columns: dict[str, Any] = {}
    owner: dict[str, str] = {}
    registered: list[tuple[str, type[GainPolicy] | type[Strategy]]] = [
        *policies().items(),
        *strategies().items(),
    ]
    for name, cls in registered:
        for column, default in cls.stat_columns.items():
            if column in columns and not _same(columns[column], default):
                raise ValueError(
                    f"{name!r} declares the stat column {column!r} = {default!r}, "
                    f"{owner[column]!r} = {columns[column]!r}"
                )
            columns.setdefault(column, default)
            owner.setdefault(column, name)
    return columns


def _same(a: Any, b: Any) -> bool:
    """Equal values, NaN equal to NaN."""
    return bool(a == b) or (a != a and b != b)
