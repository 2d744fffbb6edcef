"""Reachable-wrist polyhedra (002 Sec. IV-B), computed once per robot and cached on disk.

For each arm, wrist positions relative to the shoulder are sampled over the ranges of the arm's
joints up to the elbow, in the torso frame. The coronal plane (torso x = 0 through the shoulder)
splits them into a front and a back set; each set's convex hull is one polyhedron, stored with
its centroid at the origin (the landing search places the centroid on the MPIP).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from fallbench.robots.cache import cache_root
from fallbench.robots.description import RobotDescription

SAMPLES = 4000
FACET_TOLERANCE = 1e-12  # m
SEED = 0


@dataclass
class ReachPolyhedron:
    vertices: np.ndarray  # (n, 3) m, torso frame, centroid at the origin
    _facets: np.ndarray | None = field(
        default=None, repr=False
    )  # (k, 4): outward unit normal n, offset d; inside: n'x + d <= 0

    def contains(self, offset: np.ndarray) -> bool:
        """Whether `offset` (m, torso frame, from the centroid) lies inside the polyhedron (the convex
        hull of the vertices: on the inner side of every facet's plane, to FACET_TOLERANCE)."""
        if self._facets is None:
            from scipy.spatial import ConvexHull

            self._facets = ConvexHull(self.vertices).equations
        return bool((self._facets[:, :3] @ offset + self._facets[:, 3] <= FACET_TOLERANCE).all())


def sample_wrist_offsets(
    model: pin.Model, robot: RobotDescription, side: str, samples: int = SAMPLES
) -> np.ndarray:
    """(samples, 3) wrist - shoulder in the torso frame, arm joints up to the elbow drawn uniformly."""
    arm = robot.arms[side]
    data = model.createData()
    chain = list(model.supports[model.getJointId(arm.elbow_joint)])
    joints = chain[chain.index(model.getJointId(arm.shoulder_joint)) :]  # shoulder .. elbow
    q = pin.neutral(model)
    rng = np.random.default_rng(SEED)
    torso = model.getFrameId(robot.torso_body)
    shoulder, wrist = model.getJointId(arm.shoulder_joint), model.getJointId(arm.wrist_joint)
    offsets = np.empty((samples, 3))
    for k in range(samples):
        for j in joints:
            i = model.joints[j].idx_q
            q[i] = rng.uniform(model.lowerPositionLimit[i], model.upperPositionLimit[i])
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        rotation = robot.torso_frame(data.oMf[torso].rotation)
        offsets[k] = rotation.T @ (data.oMi[wrist].translation - data.oMi[shoulder].translation)
    return offsets


def _hull_vertices(points: np.ndarray) -> np.ndarray:
    from scipy.spatial import ConvexHull

    vertices = points[ConvexHull(points).vertices]
    return vertices - vertices.mean(axis=0)


def _cache_file(robot: RobotDescription) -> Path:
    key = hashlib.sha256(
        robot.model_path.read_bytes() + f"{SAMPLES}:{SEED}:{robot.arms}:{robot.torso_axes}".encode()
    ).hexdigest()[:16]
    return cache_root() / f"reach-{robot.name}-{key}.npz"


def compute_polyhedra(model: pin.Model, robot: RobotDescription) -> dict[str, np.ndarray]:
    """`<side>:front` and `<side>:back` hull vertices for each arm."""
    polyhedra = {}
    for side in robot.arms:
        offsets = sample_wrist_offsets(model, robot, side)
        polyhedra[f"{side}:front"] = _hull_vertices(offsets[offsets[:, 0] >= 0])
        polyhedra[f"{side}:back"] = _hull_vertices(offsets[offsets[:, 0] <= 0])
    return polyhedra


_LOADED: dict[str, dict[str, ReachPolyhedron]] = {}


def reach_polyhedra(robot: RobotDescription, model: pin.Model) -> dict[str, ReachPolyhedron]:
    """The polyhedra, from this process, else the disk cache (written atomically, keyed by the URDF)."""
    if robot.name not in _LOADED:
        _LOADED[robot.name] = _load_or_compute(robot, model)
    return _LOADED[robot.name]


def _load_or_compute(robot: RobotDescription, model: pin.Model) -> dict[str, ReachPolyhedron]:
    path = _cache_file(robot)
    if path.exists():
        with np.load(path) as stored:
            return {key: ReachPolyhedron(stored[key]) for key in stored.files}
    polyhedra = compute_polyhedra(model, robot)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as handle:
        np.savez(handle, **polyhedra)
    os.replace(handle.name, path)
    return {key: ReachPolyhedron(vertices) for key, vertices in polyhedra.items()}
