"""004's figures that scenarios/direction.yaml mirrors: the push each starts from and the strategy
004 picks there. The store does not say which figure a family mirrors, so a family is matched to a
figure by its conditions, read from the spec of one of its runs: its push (force on TALOS, N, and
direction, deg) and its layout (004's four objects). A scenario field naming the figure (e.g.
`mirrors: {paper: "004", figure: 1, choice: take_step}`), carried into the store, would replace
this matching."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from ruamel.yaml import YAML

from fallbench.report.selection import among_objects, pushed, set_conditions
from fallbench.results import store

FORCED_MODE = "param:policy_params.direction.mode"  # a strategy forced per point (Fig. 10's ablation)
LAYOUT_OBJECTS = 4  # 004's Fig. 1 layout: table, person, cabinet, post


@dataclass(frozen=True)
class Figure004:
    """One figure of 004 with a single push: its conditions and the strategy 004 picks."""

    figure: str  # as 004 numbers it
    force: float  # N on TALOS: 004's force x 90.3 / 54 (TALOS's mass over 004's robot's)
    direction: float  # deg, 0 = robot forward
    choice: str  # 004's strategy, as papers/direction.py classes `direction_strategy`


FIGURES = (
    Figure004("Fig. 1", 384.0, 0.0, "take_step"),
    Figure004("Fig. 6", 351.0, 180.0, "no_action"),
    Figure004("Fig. 7", 351.0, 0.0, "lift_leg"),
    Figure004("Fig. 8", 393.0, 0.0, "take_step+pis"),  # also Fig. 10's push, each strategy forced
    Figure004("Fig. 9", 618.0, 270.0, "no_action+wbis"),
)


FORCE_SCALE = "param:scale:force"  # the push force's factor on a robot other than the file's


def _conditions(results: Path, run: pd.Series) -> tuple[float, float, int]:
    """(push force N on the file's robot, push direction deg in [0, 360), objects) of a stored run."""
    spec = YAML(typ="safe", pure=True).load((store.run_dir(results, run.run_id) / "spec.yaml").read_text())
    scenario = spec["scenario"]
    push = scenario.get("push") or {}
    scale = run.get(FORCE_SCALE)
    force = float(push.get("force", 0.0)) / (float(scale) if pd.notna(scale) else 1.0)
    return force, float(push.get("direction", 0.0)) % 360.0, len(scenario.get("obstacles") or [])


def mirrors(runs: pd.DataFrame, results: Path) -> dict[str, Figure004]:
    """Scenario family -> the figure of 004 it mirrors: families with `direction` runs among 004's
    four objects, every condition set and the push not swept, whose push is a figure's."""
    candidates = runs[among_objects(runs) & set_conditions(runs) & ~pushed(runs)]
    found = {}
    for family, group in candidates.groupby("scenario", sort=True):
        if "direction" not in set(group.pre_impact):
            continue
        force, direction, objects = _conditions(results, group.iloc[0])
        for figure in FIGURES:
            if objects == LAYOUT_OBJECTS and (figure.force, figure.direction) == (round(force), direction):
                found[str(family)] = figure
    return found


def expected_choices(runs: pd.DataFrame, found: dict[str, Figure004]) -> dict[str, str]:
    """Family -> 004's choice, in 004's figure order, for the mirrors where `direction` chooses
    (not those forcing a strategy per point)."""
    forced = set(runs.loc[runs[FORCED_MODE].notna(), "scenario"]) if FORCED_MODE in runs else set()
    order = {figure.figure: k for k, figure in enumerate(FIGURES)}
    chosen = [(family, figure) for family, figure in found.items() if family not in forced]
    return {family: figure.choice for family, figure in sorted(chosen, key=lambda f: order[f[1].figure])}
