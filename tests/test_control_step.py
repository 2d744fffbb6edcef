"""The control step's shortcuts give their reference computations' bits: the feet's corners moved
in one stacked product, the capture point on Python floats, the tilt from one entry of the torso's
rotation, the "found" columns read as a slice, the divergence test on Python numbers, the
takeover's flags; and the run's IMU filter, designed once per step size."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fallbench.analysis.sensors import ImuModel
from fallbench.assembly import run_world
from fallbench.registry import load_policy, load_strategy
from fallbench.scenario import Scenario
from fallbench.sim.episode import Episode
from fallbench.sim.events import (
    _distance_to_hull,
    _hull,
    acc_norm,
    capture_point,
    capture_point_distance,
    tilt_deg,
    tilt_from_cosine,
)
from fallbench.sim.rest import DivergenceWatch, divergence
from fallbench.sim.sensing import up_column
from fallbench.sim.support import world_corners
from fallbench.sim.takeover import Takeover
from fallbench.sim.world import found_columns

FORCE = {"talos": 370.0, "g1": 140.0}  # N for 0.1 s: the robot falls, its feet rolling (G1: TALOS's x 33/90)


def _episode(robot: str) -> Episode:
    push = {"force": FORCE[robot], "duration": 0.1, "start": 0.05, "direction": 30.0}
    scenario = Scenario(name="push", robot=robot, duration=0.6, push=push)
    world = run_world(scenario)
    return Episode(
        world, scenario, load_policy("stiff")(world, scenario), load_strategy("none")(world, scenario), "none"
    )


@pytest.mark.parametrize("robot", ["talos", "g1"])
def test_feet_corners_are_those_of_each_geom_in_turn(robot: str) -> None:
    episode = _episode(robot)
    support = episode.sensing.support
    rng = np.random.default_rng(0)
    compared = 0
    while not episode.finished:
        episode.act(episode.sense())
        found = rng.random(len(episode.world.contact_bodies)) < 0.7
        touching = [k for k, i in enumerate(support.columns) if found[i]]
        expected = (
            np.concatenate(
                [world_corners(episode.data, support.geoms[k], support.corners[k]) for k in touching]
            )[:, :2]
            if touching
            else np.zeros((0, 2))
        )
        points = support.points(episode.data, found)
        assert points.shape == expected.shape and points.tobytes() == expected.tobytes()
        compared += len(touching)
    assert compared > 100


def test_capture_point_distance_is_the_numpy_capture_points() -> None:
    rng = np.random.default_rng(1)
    for _ in range(2000):
        com = rng.normal(0.0, 0.2, 3) + [0.0, 0.0, 0.9]
        velocity = rng.normal(0.0, 0.8, 3)
        support = rng.normal(0.0, 0.1, (int(rng.integers(1, 40)), 2))
        point = capture_point(com, velocity)
        expected = _distance_to_hull(float(point[0]), float(point[1]), _hull(support))
        assert capture_point_distance(com, velocity, support) == expected  # the same bits
    assert math.isnan(capture_point_distance(com, velocity, np.zeros((0, 2))))


@pytest.mark.parametrize(
    "axes",
    [
        ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)),
        ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
    ],
)
def test_the_tilt_from_one_entry_is_the_torso_frames(axes) -> None:
    up = up_column(axes)
    assert up is not None
    rng = np.random.default_rng(5)
    rotations = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(3000)] + [np.eye(3), -np.eye(3)]
    for rotation in rotations:
        frame = rotation @ np.array(axes).T  # `RobotDescription.torso_frame`
        index, sign = up
        assert tilt_from_cosine(sign * float(rotation.reshape(-1)[index])) == tilt_deg(frame)
    assert up_column(((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.6, 0.8))) is None  # through the product


def test_acc_norm_is_numpys() -> None:
    for acc in np.random.default_rng(2).normal(0.0, 30.0, (2000, 3)):
        assert acc_norm(acc) == float(np.linalg.norm(acc))


def test_found_columns_read_the_same_columns() -> None:
    rows = np.random.default_rng(3).random((10, 240))
    for columns in (np.arange(26, 234, 4), np.array([3, 9, 11]), np.array([5]), np.arange(7, 8)):
        chosen = found_columns(columns)
        np.testing.assert_array_equal(rows[:, chosen], np.take(rows, columns, axis=1))
    assert isinstance(found_columns(np.arange(26, 234, 4)), slice)


def test_the_divergence_watch_reads_what_divergence_reads() -> None:
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>'
    )
    data = mujoco.MjData(model)
    watch = DivergenceWatch(data)
    assert watch.reason() is None and divergence(data) is None
    data.qacc[2] = np.nan
    assert watch.reason() == divergence(data) == "non-finite state"
    data.qacc[2] = np.inf
    assert watch.reason() == divergence(data) == "non-finite state"
    data.qacc[2] = 0.0
    data.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 1
    assert watch.reason() == divergence(data) == "mjWARN_BADQACC"


def test_the_takeover_flags_follow_the_switched_motors(world) -> None:
    takeover = Takeover(world, Scenario(name="t").timing, per_chain=False)
    q = np.zeros(world.model.nu)
    assert (takeover.any_switched, takeover.all_switched) == (False, False)
    some = np.zeros(world.model.nu, dtype=bool)
    some[:3] = True
    takeover.switch(some, q, 0.1)
    assert (takeover.any_switched, takeover.all_switched) == (True, False)
    takeover.switch(np.ones(world.model.nu, dtype=bool), q, 0.2)
    assert (takeover.any_switched, takeover.all_switched) == (True, True)


def test_the_imu_filter_is_the_same_on_every_call() -> None:
    acc = np.random.default_rng(4).normal(0.0, 30.0, (500, 3))
    imu = ImuModel()
    first = imu.filtered(acc, 0.0005)
    assert imu.filtered(acc, 0.00025).tobytes() != first.tobytes()
    assert imu.filtered(acc, 0.0005).tobytes() == first.tobytes()
