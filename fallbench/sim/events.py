"""Fall and impact detection, as a controller on the robot would see them.

Three fall detectors, each usable on its own (plain numbers in, no simulator: the signals of
`capture_point_distance`, `tilt_deg` and `acc_norm`, as `sim/sensing.py` reads them):

- `capture_point`: the instantaneous capture point xi = c_xy + c_dot_xy / omega0, omega0 =
  sqrt(g / z_c) (Pratt et al. 2006, the fall trigger of 004 Sec. III-D), leaves the support
  polygon by more than a margin;
- `tilt`: the torso tilts past a threshold (000);
- `freefall`: the IMU reads free fall for a hold time.

`FallDetector` runs the three side by side: the fall is declared by the earliest of the selected
ones, and every detector's own firing time is kept so that their lead times can be compared.
`SignalLog` keeps the three signals themselves, so that any threshold can be judged afterwards
(`fallbench/analysis/detection.py`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from fallbench.scenario import Scenario

GRAVITY = 9.81  # m/s^2
METHODS = ("capture_point", "tilt", "freefall")


def tilt_deg(rotation: np.ndarray) -> float:
    """Angle between a body's z axis and the world vertical, deg."""
    return tilt_from_cosine(float(rotation[2, 2]))


def tilt_from_cosine(cosine: float) -> float:
    """deg: `tilt_deg` of a rotation whose (2, 2) entry is `cosine`."""
    return math.degrees(math.acos(min(max(cosine, -1.0), 1.0)))  # np.clip's value, 3 -> 0.4 us a call


def acc_norm(imu_acc: np.ndarray) -> float:
    """m/s^2: the accelerometer's norm as np.linalg.norm computes it (the square root of the dot
    product), without its checks (~3 us a call)."""
    return math.sqrt(float(np.dot(imu_acc, imu_acc)))


def capture_point(com: np.ndarray, com_velocity: np.ndarray, gravity: float = GRAVITY) -> np.ndarray:
    """Instantaneous capture point (m, ground plane) of the linear inverted pendulum at the CoM's
    height: xi = c_xy + c_dot_xy / omega0, omega0 = sqrt(g / z_c)."""
    omega0 = math.sqrt(gravity / max(float(com[2]), 1e-3))
    return np.asarray(com[:2], dtype=float) + np.asarray(com_velocity[:2], dtype=float) / omega0


Point = tuple[float, float]  # m, on the ground plane


def capture_point_distance(
    com: np.ndarray, com_velocity: np.ndarray, support_points: np.ndarray, gravity: float = GRAVITY
) -> float:
    """m: the capture point's signed distance to the support polygon of `support_points` (positive
    outside, see `signed_distance`); NaN without support points (airborne)."""
    if not len(support_points):
        return math.nan
    return support_distance(
        np.asarray(com, dtype=float).tolist(),
        np.asarray(com_velocity, dtype=float).tolist(),
        np.asarray(support_points, dtype=float)[:, :2].tolist(),
        gravity,
    )


def support_distance(
    com: list[float], com_velocity: list[float], support_points: list[list[float]], gravity: float = GRAVITY
) -> float:
    """`capture_point_distance` on Python floats (a control step's: its NumPy calls cost more than
    its arithmetic), for at least one support point. `capture_point`'s division and sum are the
    same per axis as NumPy's element by element."""
    omega0 = math.sqrt(gravity / max(com[2], 1e-3))
    x = com[0] + com_velocity[0] / omega0
    y = com[1] + com_velocity[1] / omega0
    return _distance_to_hull(x, y, _hull_of(support_points))


def support_polygon(points: np.ndarray) -> np.ndarray:
    """Vertices (k, 2), counter-clockwise, of the convex hull of ground-plane points (n, 2).
    Fewer than three points, or collinear ones, give the degenerate hull: a segment or a point.

    Andrew's monotone chain: the hull of a few foot corners, once per control step until impact;
    scipy's Qhull would do it too, but importing scipy.spatial adds ~0.3 s to every run's start-up."""
    return np.array(_hull(points), dtype=float).reshape(-1, 2)


def _hull(points: np.ndarray) -> list[Point]:
    """`support_polygon`'s vertices (m) as Python floats: the same arithmetic as NumPy's, and on
    some 60 foot corners per control step faster than NumPy's per-call cost."""
    return _hull_of(np.asarray(points, dtype=float)[:, :2].tolist())


def _hull_of(points: list[list[float]]) -> list[Point]:
    """`_hull` of points given as [x, y] lists (m)."""
    ordered: list[Point] = sorted(set(map(tuple, points)))  # distinct points sorted by x, then y
    if len(ordered) <= 2:
        return ordered
    lower, upper = _chain(ordered), _chain(ordered[::-1])
    return lower[:-1] + upper[:-1]


def _chain(points: list[Point]) -> list[Point]:
    """One half of the hull: the points where the chain turns left (collinear ones dropped)."""
    chain: list[Point] = []
    pop, append, length = chain.pop, chain.append, 0  # (the list's methods and length, held: ~15 % faster)
    for point in points:
        x, y = point
        while length >= 2:
            origin_x, origin_y = chain[length - 2]
            last_x, last_y = chain[length - 1]
            # the cross product (last - origin) x (point - origin): > 0 turns left
            if (last_x - origin_x) * (y - origin_y) - (last_y - origin_y) * (x - origin_x) > 0:
                break
            pop()
            length -= 1
        append(point)
        length += 1
    return chain


def signed_distance(point: np.ndarray, polygon: np.ndarray) -> float:
    """Distance (m) from a ground-plane point to a convex polygon (counter-clockwise vertices):
    positive outside, negative inside (minus the distance to the nearest edge)."""
    vertices = [(x, y) for x, y in np.asarray(polygon, dtype=float).reshape(-1, 2).tolist()]
    return _distance_to_hull(float(point[0]), float(point[1]), vertices)


def _distance_to_hull(x: float, y: float, polygon: list[Point]) -> float:
    """`signed_distance` of the point (x, y) (m) to the polygon of `_hull`, on Python floats."""
    if not polygon:
        return math.inf
    distances = []
    inside = len(polygon) >= 3
    for (start_x, start_y), (end_x, end_y) in zip(polygon, polygon[1:] + polygon[:1]):
        edge_x, edge_y = end_x - start_x, end_y - start_y
        offset_x, offset_y = x - start_x, y - start_y
        length2 = edge_x * edge_x + edge_y * edge_y
        along = (offset_x * edge_x + offset_y * edge_y) / (length2 if length2 > 1e-18 else 1.0)
        along = min(max(along, 0.0), 1.0)
        nearest_x, nearest_y = offset_x - along * edge_x, offset_y - along * edge_y
        distances.append(math.sqrt(nearest_x * nearest_x + nearest_y * nearest_y))
        inside = inside and edge_x * offset_y - edge_y * offset_x >= 0
    distance = min(distances)
    return -distance if inside else distance


@dataclass
class CapturePointDetector:
    """The fall trigger: the capture point is more than `margin` m outside the support polygon.
    Without support points (airborne) it cannot judge and does not fire."""

    margin: float  # m
    time: float | None = None
    distance: float = -math.inf  # m, capture point's signed distance to the polygon at the last observation

    def observe(self, t: float, distance: float) -> bool:
        """One control step of a state with support: the capture point's distance (m,
        `capture_point_distance`) to the support polygon. True once fired."""
        if self.time is None:
            self.distance = distance
            if self.distance > self.margin:
                self.time = t
        return self.time is not None


@dataclass
class TiltDetector:
    """The torso tilts past `threshold` deg (000's trigger)."""

    threshold: float  # deg
    time: float | None = None

    def observe(self, t: float, tilt: float) -> bool:
        """One control step: the torso's tilt (deg, `tilt_deg`). True once fired."""
        if self.time is None and tilt > self.threshold:
            self.time = t
        return self.time is not None


@dataclass
class FreefallDetector:
    """The accelerometer norm has stayed below `threshold` for `hold` s; the fall starts when it
    first dropped. The hold matters at t = 0 of a standing start: the feet touch the floor without
    load yet, so the first reading is free fall although the robot stands."""

    threshold: float  # m/s^2
    hold: float  # s
    time: float | None = None
    since: float | None = None

    def observe(self, t: float, norm: float) -> bool:
        """One control step: the accelerometer's norm (m/s^2, `acc_norm`). True once fired."""
        if self.time is not None:
            return True
        if norm >= self.threshold:
            self.since = None
        elif self.since is None:
            self.since = t
        if self.since is not None and t - self.since >= self.hold - 1e-9:
            self.time = self.since
        return self.time is not None


@dataclass
class FallDetector:
    """The three detectors side by side. The fall is declared by the earliest of `methods`;
    `observe` goes on feeding the others so that `times` records when each fired."""

    methods: tuple[str, ...]
    capture: CapturePointDetector
    tilt: TiltDetector
    freefall: FreefallDetector
    time: float | None = None
    reason: str = ""
    times: dict[str, float] = field(default_factory=dict)

    def observe(self, t: float, supported: bool, distance: float, tilt: float, acc: float) -> bool:
        """Feed every detector one control step's signals: whether a foot touches (`supported`), the
        capture point's distance to the support (m; read only with support), the torso's tilt (deg)
        and the accelerometer's norm (m/s^2). True once the fall is declared."""
        if supported:
            self.capture.observe(t, distance)
        self.tilt.observe(t, tilt)
        self.freefall.observe(t, acc)
        return self.declare()

    def declare(self) -> bool:
        """Note each detector's firing time and declare the fall at the earliest selected one."""
        if len(self.times) < len(METHODS):  # a detector's time, once set, never changes
            detectors = {"capture_point": self.capture, "tilt": self.tilt, "freefall": self.freefall}
            self.times = {name: d.time for name, d in detectors.items() if d.time is not None}
        if self.time is None:
            fired = [(self.times[m], METHODS.index(m), m) for m in self.methods if m in self.times]
            if fired:
                self.time, _, self.reason = min(fired)
        return self.time is not None

    @property
    def all_fired(self) -> bool:
        return len(self.times) == len(METHODS)


def make_fall_detector(scenario: Scenario) -> FallDetector:
    """The fall detectors with the scenario's `detection` settings."""
    detection = scenario.detection
    return FallDetector(
        detection.method,
        CapturePointDetector(detection.capture_point_margin),
        TiltDetector(detection.tilt),
        FreefallDetector(detection.freefall, detection.freefall_hold),
    )


@dataclass
class ImpactDetector:
    """Impact: the first contact, after the fall starts, of a body that was not touching then.

    In a drop nothing touches at the start of the fall, so the feet's first contact is the impact.
    The episode does not pass it a step (a foot set down while a foot of the other leg touches,
    before the first impact: `Episode.without_steps`): the foot joins the support instead.
    """

    support: set[str] | None = None  # bodies in contact when the fall was detected
    time: float | None = None
    bodies: list[str] = field(default_factory=list)

    def start(self, touching: set[str]) -> None:
        if self.support is None:
            self.support = set(touching)

    def update(self, t: float, touching: set[str]) -> bool:
        if self.time is None and self.support is not None:
            new = sorted(touching - self.support)
            if new:
                self.time, self.bodies = t, new
        return self.time is not None


@dataclass
class SignalLog:
    """The three detectors' signals at every control step, whatever their thresholds: the capture
    point's signed distance to the support polygon (m; NaN when no foot touches), the torso tilt
    (deg) and the accelerometer norm (m/s^2). Kept from the start of the run until a body other
    than the feet first touches the world (`body_contact_time`, s: the control step whose contact
    sensors found it; the impact a detector is meant to foresee), or to the end of a run in which
    none does."""

    rows: list[tuple[float, float, float, float]] = field(default_factory=list)  # t, distance, tilt, |acc|
    body_contact_time: float | None = None

    @property
    def watching(self) -> bool:
        return self.body_contact_time is None

    def log(self, t: float, distance: float, tilt: float, acc: float, body_touching: bool) -> None:
        """One control step: the capture point's distance as `capture_point_distance` gives it (m,
        NaN without support), the tilt (deg, `tilt_deg`), the accelerometer's norm (m/s^2, `acc_norm`)."""
        if not self.watching:
            return
        if body_touching:
            self.body_contact_time = t
            return
        self.rows.append((t, distance, tilt, acc))

    def array(self) -> np.ndarray:
        """(steps, 4): t (s), capture-point distance (m), tilt (deg), accelerometer norm (m/s^2)."""
        return np.array(self.rows, dtype=float).reshape(-1, 4)


@dataclass
class FallWatch:
    """After a detection: whether the fall goes on. It is over (`update` returns True, once) when,
    for `hold` s, the capture point stays at least `margin` m inside the feet's support polygon and
    the torso tilt under `tilt` deg, before any body other than the feet touched; the watch ends
    without a verdict at that touch (the fall went on)."""

    margin: float  # m
    tilt: float  # deg
    hold: float  # s
    since: float | None = None
    time: float | None = None  # s, when the fall was judged over

    def update(self, t: float, distance: float, tilt: float) -> bool:
        """One control step's capture-point distance (m, NaN without support) and tilt (deg)."""
        if self.time is not None:
            return False
        if not (distance <= -self.margin and tilt < self.tilt):  # NaN: no support, not over
            self.since = None
            return False
        self.since = t if self.since is None else self.since
        if t - self.since >= self.hold - 1e-9:
            self.time = t
            return True
        return False
