"""The support polygon's points, read from the simulator: the footprint of each foot in contact.

The polygon is the convex hull of the footprints (the geometry's bounding-box corners, projected
on the ground) of the foot bodies whose contact sensors saw the environment, not of the contact
points themselves: as soon as a foot rolls onto its toe or heel under a push, its contact points
shrink to that edge, and the capture point of a push TALOS survives lies outside the edge (by up to
0.145 m at 235 N forward, measured) although the foot will roll back flat. The footprint is where
the foot can still push, so leaving it means the fall cannot be stopped without a step.
"""

from __future__ import annotations

import mujoco
import numpy as np

from fallbench.sim.world import World

UNIT_CORNERS = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T


def welded_bodies(model: mujoco.MjModel, body: int) -> list[int]:
    """The body and every descendant attached to it without a joint: one rigid body. A URDF may put
    a link's collision geometry on a fixed child (G1's pelvis: `pelvis_contour_link`)."""
    bodies = [body]
    for child in range(body + 1, model.nbody):
        if model.body_parentid[child] in bodies and model.body_jntnum[child] == 0:
            bodies.append(child)
    return bodies


def body_box_corners(model: mujoco.MjModel, body: int) -> tuple[np.ndarray, np.ndarray]:
    """A rigid body's collision geoms (its own and its welded children's, see welded_bodies) and
    the 8 corners of each one's bounding box, (n, 8, 3) in the geom frames."""
    geoms = np.flatnonzero(np.isin(model.geom_bodyid, welded_bodies(model, body)) & (model.geom_contype > 0))
    aabb = model.geom_aabb[geoms]  # centre (3) and half extents (3), geom frame
    return geoms, aabb[:, None, :3] + UNIT_CORNERS[None] * aabb[:, None, 3:]


def world_corners(data: mujoco.MjData, geoms: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(8 n, 3) world positions of geoms' corners from body_box_corners."""
    return np.concatenate(
        [c @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g] for g, c in zip(geoms, corners)]
    )


class FootSupport:
    """Ground-plane corners of the feet in contact, each control step (numpy on MjData only)."""

    def __init__(self, world: World) -> None:
        model = world.model
        feet = set(world.robot.body_groups["feet"])
        self.columns = np.array([i for i, body in enumerate(world.contact_bodies) if body in feet], dtype=int)
        self.geoms: list[np.ndarray] = []  # per foot column: the body's collision geoms
        self.corners: list[np.ndarray] = []  # per foot column: (n_geoms, 8, 3) corners, geom frame
        for i in self.columns:
            geoms, corners = body_box_corners(model, model.body(world.contact_bodies[i]).id)
            self.geoms.append(geoms)
            self.corners.append(corners)
        # per set of feet in contact (a tuple of flags over `columns`): their geoms and corners stacked
        self.stacked: dict[tuple[bool, ...], tuple[np.ndarray, np.ndarray]] = {}

    def points(self, data: mujoco.MjData, found: np.ndarray) -> np.ndarray:
        """(n, 2) ground-plane points of the feet whose contact sensors are in `found` (a mask
        over the world's contact bodies); empty when no foot touches.

        The corners of every geom of the feet in contact are moved in one stacked product, which
        multiplies each geom's (8, 3) corners by its rotation in the same BLAS call, on the same
        operands, as `world_corners` does geom after geom (the same numbers, without the per-geom
        NumPy calls: some 10 us of a control step's ~60 until a body touches)."""
        touching = tuple(found.take(self.columns).tolist())
        stacked = self.stacked.get(touching)
        if stacked is None:
            stacked = self.stacked[touching] = self.stack(touching)
        geoms, corners = stacked
        if not len(geoms):
            return np.zeros((0, 2))
        rotations = data.geom_xmat[geoms].reshape(-1, 3, 3).transpose(0, 2, 1)
        return (corners @ rotations + data.geom_xpos[geoms][:, None]).reshape(-1, 3)[:, :2]

    def stack(self, touching: tuple[bool, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The geoms (g,) and their corners (g, 8, 3) of the feet flagged in `touching`, foot by foot."""
        feet = [k for k, flag in enumerate(touching) if flag]
        if not feet:
            return np.zeros(0, dtype=int), np.zeros((0, 8, 3))
        return np.concatenate([self.geoms[k] for k in feet]), np.concatenate([self.corners[k] for k in feet])
