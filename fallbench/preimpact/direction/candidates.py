"""The candidate strategies of 004 (Secs. I, IV-B, V) and their predicted fall directions.

No Action keeps the support polygon; Lift a Leg leaves the stance foot's sole; Take a Step moves
one foot, over a grid of targets, and the support becomes the hull of both soles. The robot tips
about the polygon's boundary point nearest the capture point (pendulum.py). A step changes the
support only when it lands: its prediction follows Lift a Leg's pendulum until then, and a target
is kept only if the foot gets there in half No Action's fall time and lands clear of the objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fallbench.analysis.safe_regions import Circle
from fallbench.preimpact.direction.pendulum import Rollout, rollout
from fallbench.preimpact.direction.support import contains, nearest_pivot
from fallbench.sim.events import capture_point, support_polygon


@dataclass(frozen=True)
class StepGrid:
    radii: np.ndarray  # m, step lengths from the swing foot's current centre
    headings: np.ndarray  # rad, world
    time_offset: float  # s: a step of length d lands time_offset + time_per_m d after the control trigger
    time_per_m: float  # s/m (measured: scenarios/direction_step_timing.yaml, docs/methods/direction.md)
    min_separation: (
        float  # m from the stance foot's centre to the target, across (toward the swing foot's side)
    )
    max_separation: float  # m, the maximum leg spread

    def landing_time(self, length: float) -> float:
        """s from the control trigger until a step of `length` m lands (the swing lifts, then sets down)."""
        return self.time_offset + self.time_per_m * length


@dataclass
class Candidate:
    kind: str  # no_action | lift_leg | take_step
    swing: str | None  # side of the moving foot
    target: np.ndarray | None  # m, (2,) swing-foot centre after a step
    polygon: np.ndarray  # support polygon once the strategy is in place
    direction: float = math.nan  # rad, predicted theta_f
    fall_time: float = math.nan  # s to touchdown
    score: float = math.inf
    step: np.ndarray | None = None  # m, (2,) target minus the swing foot's centre (Take a Step)
    capture_margin: float = (
        -math.inf
    )  # m: the capture point's distance inside the polygon (negative: outside), at landing for a step
    capturing: bool = False  # the fall would stop on the new polygon (capture point inside, or the pendulum falls back onto it)

    @property
    def name(self) -> str:
        return self.kind if self.swing is None else f"{self.kind}_{self.swing}"


@dataclass(frozen=True)
class FallState:
    com: np.ndarray  # m, (3,)
    velocity: np.ndarray  # m/s, (3,)
    floor_z: float  # m
    touchdown_height: float  # m above the floor


def predict(
    polygons: list[np.ndarray], coms: np.ndarray, velocities: np.ndarray, state: FallState
) -> tuple[Rollout, np.ndarray]:
    """Pendulum rollouts about each polygon's pivot; and whether the fall stops on the polygon: the
    capture point is inside it, or the pendulum swings back across its pivot, over the polygon (a
    rigid body standing on a polygon cannot tip about an edge into its own sole: it settles on it;
    a CoM landing behind the front edge, too slow to rise over it, does this)."""
    pivots, edges, inside, outward = [], [], [], []
    for polygon, com, velocity in zip(polygons, coms, velocities):
        xi = capture_point(com, velocity)
        pivot = nearest_pivot(polygon, xi)
        pivots.append(pivot.point)
        edges.append(np.zeros(2) if pivot.edge is None else pivot.edge)
        inside.append(contains(polygon, xi))
        outward.append(xi[:2] - pivot.point)  # from the boundary toward the capture point outside it
    roll = rollout(np.array(pivots), np.array(edges), coms, velocities, state.floor_z, state.touchdown_height)
    back = np.einsum("ij,ij->i", roll.end[:, :2] - np.array(pivots), np.array(outward)) < 0.0
    return roll, np.array(inside) | back


def capture_margin(polygon: np.ndarray, com: np.ndarray, velocity: np.ndarray) -> float:
    """m: how far the capture point lies inside `polygon` (negative outside it)."""
    xi = capture_point(com, velocity)
    gap = float(np.linalg.norm(xi[:2] - nearest_pivot(polygon, xi).point))
    return gap if contains(polygon, xi) else -gap


def clear_of(point: np.ndarray, reach: float, objects: list[Circle]) -> bool:
    """Whether a disc of radius `reach` at `point` stays outside every (ungrown) object circle."""
    return all(float(np.linalg.norm(point - c.centre)) > c.radius + reach for c in objects)


def step_targets(
    soles: dict[str, np.ndarray], swing: str, grid: StepGrid, objects: list[Circle]
) -> list[np.ndarray]:
    """Grid targets for the swing foot's centre within the leg spread, on the swing foot's own side
    of the stance foot (no crossing of the legs) and clear of the objects."""
    stance = next(s for s in soles if s != swing)
    centre, other = soles[swing].mean(axis=0), soles[stance].mean(axis=0)
    side = (centre - other) / float(
        np.linalg.norm(centre - other)
    )  # from the stance foot toward the swing foot
    reach = float(np.max(np.linalg.norm(soles[swing] - centre, axis=1)))
    targets = []
    for r in grid.radii:
        for heading in grid.headings:
            target = centre + r * np.array([math.cos(heading), math.sin(heading)])
            offset = target - other
            if (
                float(offset @ side) >= grid.min_separation
                and float(np.linalg.norm(offset)) <= grid.max_separation
                and clear_of(target, reach, objects)
            ):
                targets.append(target)
    return targets


def landed_states(lifted: Rollout, index: int, travel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CoM states (m, m/s; (n, 3) each) after `travel` s (n,) of a fall on the stance foot alone
    (rollout `index` of `lifted`): where a step's support changes."""
    at = np.minimum(np.round(travel / lifted.dt).astype(int), int(lifted.touchdown_step[index]))
    return lifted.com[index, at], lifted.velocity[index, at]


def step_directions(
    polygons: list[np.ndarray], coms: np.ndarray, velocities: np.ndarray, origin: np.ndarray, state: FallState
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(directions rad from `origin`, fall times s after landing, capture point inside) of falls that
    continue on each step's new polygon from its landing state."""
    roll, inside = predict(polygons, coms, velocities, state)
    end = roll.end[:, :2] - origin[:2]
    return np.arctan2(end[:, 1], end[:, 0]) % (2 * math.pi), roll.time, inside


def evaluate(
    soles: dict[str, np.ndarray], state: FallState, grid: StepGrid, objects: list[Circle]
) -> tuple[list[Candidate], Rollout]:
    """Every candidate with its predicted direction and fall time (scores are set by the caller),
    and the rollouts of No Action and Lift a Leg (a step falls like Lift a Leg until it lands)."""
    both = support_polygon(np.vstack(list(soles.values())))
    fixed = [Candidate("no_action", None, None, both)]
    fixed += [
        Candidate("lift_leg", side, None, soles[other])
        for side, other in (("left", "right"), ("right", "left"))
    ]
    start = np.repeat(state.com[None], len(fixed), axis=0)
    start_v = np.repeat(state.velocity[None], len(fixed), axis=0)
    fixed_roll, fixed_inside = predict([c.polygon for c in fixed], start, start_v, state)
    for k, candidate in enumerate(fixed):
        candidate.direction, candidate.fall_time = float(fixed_roll.direction[k]), float(fixed_roll.time[k])
        candidate.capturing = bool(fixed_inside[k])
    steps: list[Candidate] = []
    deadline = 0.5 * fixed[0].fall_time
    for k, lifted in enumerate(fixed[1:], start=1):
        swing = lifted.swing
        assert swing is not None
        stance = next(s for s in soles if s != swing)
        centre = soles[swing].mean(axis=0)
        targets = [
            t
            for t in step_targets(soles, swing, grid, objects)
            if grid.landing_time(float(np.linalg.norm(t - centre))) <= deadline
        ]
        if not targets:
            continue
        travel = np.array([grid.landing_time(float(np.linalg.norm(t - centre))) for t in targets])
        side = [
            Candidate(
                "take_step",
                swing,
                t,
                support_polygon(np.vstack([soles[stance], soles[swing] + (t - centre)])),
                step=t - centre,
            )
            for t in targets
        ]
        coms, vels = landed_states(fixed_roll, k, travel)
        directions, times, inside = step_directions([c.polygon for c in side], coms, vels, state.com, state)
        for j, candidate in enumerate(side):
            candidate.direction, candidate.fall_time, candidate.capturing = (
                float(directions[j]),
                travel[j] + float(times[j]),
                bool(inside[j]),
            )
            candidate.capture_margin = capture_margin(candidate.polygon, coms[j], vels[j])
        steps += side
    return fixed + steps, fixed_roll
