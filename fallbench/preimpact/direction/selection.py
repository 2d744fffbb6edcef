"""Choosing a strategy (004 Secs. IV-A, V; the paper's rule is lost in extraction and rebuilt
here): score every candidate's predicted direction; take the best candidate of the first class,
in the order No Action, Lift a Leg, Take a Step, whose score is at most 1 (safe); if none is safe,
No Action (`when_none_safe: no_action`: nothing the prediction can justify, as 004's Fig. 9 falls
with No Action while unsafe) or the best of all (`best`). Lift a Leg and Take a Step run with
partial inertia shaping; No Action chosen while unsafe runs whole-body inertia shaping (Fig. 9).
`mode` forces one choice (Fig. 10)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.analysis.safe_regions import SafeRegion, score
from fallbench.preimpact.direction.candidates import Candidate
from fallbench.preimpact.direction.scoring import desired_direction

CLASSES = ("no_action", "lift_leg", "take_step")
MODES = ("auto", "no_action", "lift_leg", "take_step", "take_step_pis", "whole_body_is")
SELECTIONS = ("cascade", "argmin")
SIDES = ("", "left", "right")
PREDICTORS = ("pendulum", "rollout", "oracle")
PARTIAL_SHAPING = ("upper_body", "eq7", "off")
WHOLE_BODY_SHAPING = ("off", "on")
CAPTURE = ("off", "prefer")
WHEN_NONE_SAFE = ("best", "no_action")


@dataclass(frozen=True)
class Forced:
    """A forced candidate's side and step (for measuring steering authority): empty or None
    fields leave the choice to the score."""

    swing_side: str = ""  # left | right
    step_length: float | None = None  # m
    step_bearing: float | None = None  # deg off No Action's predicted fall direction, + counterclockwise


@dataclass
class Plan:
    chosen: Candidate
    inertia_shaping: str  # "" (none), "pis" (partial) or "wbis" (whole body)
    desired: float | None  # rad, theta_d: the bisector toward which inertia shaping turns the fall
    candidates: list[Candidate]

    @property
    def label(self) -> str:
        """e.g. take_step_right+pis."""
        return self.chosen.name + (f"+{self.inertia_shaping}" if self.inertia_shaping else "")


def _best(candidates: list[Candidate], kind: str) -> Candidate | None:
    members = [c for c in candidates if c.kind == kind]
    return min(members, key=lambda c: c.score) if members else None


def _forced(candidates: list[Candidate], kind: str, no_action: Candidate, forced: Forced) -> Candidate | None:
    """The candidate of `kind` on the forced side whose step is nearest the forced one (any
    capturing ones included: a forced step is measured, not judged), else None."""
    members = [c for c in candidates if c.kind == kind and forced.swing_side in ("", c.swing)]
    if kind != "take_step" or forced.step_length is None or forced.step_bearing is None:
        return min(members, key=lambda c: c.score) if members else None
    heading = no_action.direction + math.radians(forced.step_bearing)
    wanted = forced.step_length * np.array([math.cos(heading), math.sin(heading)])
    steps = [c for c in members if c.step is not None]
    return min(steps, key=lambda c: float(np.linalg.norm(c.step - wanted))) if steps else None


def choose(
    candidates: list[Candidate],
    regions: list[SafeRegion],
    mode: str = "auto",
    selection: str = "cascade",
    w1: float = 0.5,
    w2: float = 0.5,
    allow_capture: bool = False,
    forced: Forced = Forced(),
    capture: str = "off",
    when_none_safe: str = "no_action",
) -> Plan:
    for candidate in candidates:
        candidate.score = score(candidate.direction, regions, w1, w2)
    usable = [c for c in candidates if c.kind == "no_action" or allow_capture or not c.capturing]
    no_action = _best(usable, "no_action")
    assert no_action is not None
    capturing = [c for c in candidates if c.kind == "take_step" and c.capture_margin > 0.0]
    if mode == "auto" and capture == "prefer" and capturing:  # stop the fall: the widest capture margin
        chosen = max(capturing, key=lambda c: c.capture_margin)
        return Plan(chosen, "", None, candidates)
    if mode == "auto":
        best_of_all = min(usable, key=lambda c: c.score)
        ranked = [_best(usable, kind) for kind in CLASSES] if selection == "cascade" else [best_of_all]
        chosen = next((c for c in ranked if c is not None and c.score <= 1.0), None)  # the first safe
        chosen = chosen or (no_action if when_none_safe == "no_action" else best_of_all)
        shaping = (
            "pis"
            if chosen.kind != "no_action"
            else ("wbis" if chosen.score > 1.0 and math.isfinite(chosen.score) else "")
        )
    else:
        kind = {"take_step_pis": "take_step", "whole_body_is": "no_action"}.get(mode, mode)
        chosen = (
            _forced(candidates, kind, no_action, forced)
            if forced.swing_side or forced.step_length is not None
            else _best(usable, kind)
        ) or no_action
        shaping = {"take_step_pis": "pis", "whole_body_is": "wbis"}.get(mode, "")
        shaping = shaping if chosen.kind == kind else ""
    return Plan(chosen, shaping, desired_direction(chosen.direction, regions), candidates)
