"""Pinocchio's model terms agree with MuJoCo's after the joint map (same URDF, same armature)."""

from __future__ import annotations

import gc
import weakref

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from fallbench.dynamics.model import build_pinocchio, pinocchio_for
from fallbench.robots import ROBOTS
from fallbench.scenario import Scenario
from fallbench.sim import world as world_module
from fallbench.sim.world import build_world, initial_state


def _random_state(seed: int, robot: str):
    scenario = Scenario(name="t", duration=1.0, robot=robot, initial={"height": 0.3})
    world = build_world(scenario)
    data = initial_state(world, scenario)
    rng = np.random.default_rng(seed)
    quat = rng.normal(size=4)
    data.qpos[3:7] = quat / np.linalg.norm(quat)
    data.qpos[world.qpos_adr] += rng.uniform(-0.2, 0.2, size=len(world.qpos_adr))
    data.qvel[:] = rng.normal(size=world.model.nv)
    mujoco.mj_forward(world.model, data)
    return world, data


def _velocity_map(data: mujoco.MjData, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """T with v_mujoco = T v_pin (base linear velocity world <- base frame), and its rate term."""
    rotation = data.xmat[1].reshape(3, 3)
    T = np.eye(nv)
    T[:3, :3] = rotation
    v_local = rotation.T @ data.qvel[:3]
    T_dot_v = np.zeros(nv)
    T_dot_v[:3] = rotation @ np.cross(data.qvel[3:6], v_local)
    return T, T_dot_v


def _pin_to_mj_order(P, nv: int) -> np.ndarray:
    """Permutation: MuJoCo velocity index of each Pinocchio velocity index."""
    order = np.empty(nv, dtype=int)
    order[:6] = np.arange(6)
    order[6:] = P.mj_to_pin_v
    return order


@pytest.mark.parametrize("robot", ROBOTS)
def test_mass_matrix_and_nonlinear_effects_agree(robot: str) -> None:
    for seed in range(3):
        world, data = _random_state(seed, robot)
        model = world.model
        P = build_pinocchio(world)
        q, v = P.state(data.qpos, data.qvel)
        M_pin = pin.crba(P.model, P.data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        nle_pin = pin.nonLinearEffects(P.model, P.data, q, v)

        M_mj = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M_mj)  # MuJoCo 4: (model, data, dst); d.qM is gone
        T, T_dot_v = _velocity_map(data, model.nv)
        order = _pin_to_mj_order(P, model.nv)
        # In Pinocchio's velocity coordinates: M = T' M_mj T, h = T' (bias_mj + M_mj T_dot v).
        M_mj_in_pin = (T.T @ M_mj @ T)[np.ix_(order, order)]
        nle_mj_in_pin = (T.T @ (data.qfrc_bias + M_mj @ T_dot_v))[order]

        assert np.abs(M_pin - M_mj_in_pin).max() < 1e-9 * max(1.0, np.abs(M_mj).max())
        assert np.abs(nle_pin - nle_mj_in_pin).max() < 1e-8 * max(1.0, np.abs(data.qfrc_bias).max())


@pytest.mark.parametrize("robot", ROBOTS)
def test_armature_is_in_both_models(robot: str) -> None:
    world, _ = _random_state(0, robot)
    P = build_pinocchio(world)
    joints = [world.joint_names.index(j) for j in world.robot.armature]
    assert joints, "every registered robot declares its rotor inertias"
    np.testing.assert_allclose(
        world.model.dof_armature[world.qvel_adr[joints]], list(world.robot.armature.values())
    )
    np.testing.assert_allclose(P.model.armature[P.actuated_v], world.model.dof_armature[world.qvel_adr])
    if robot == "talos":  # the SRDF's rotor_params: 1e-5 kg m^2 x gear ratio 100^2
        np.testing.assert_allclose(world.model.dof_armature[world.qvel_adr[joints]], 0.1)


def test_the_pinocchio_cache_keeps_its_world_alive() -> None:
    """A cached model holds its world, so that a world evicted from the world cache cannot be freed
    and its id given to a new world, which would then get the old world's model (another robot's)."""
    world = world_module.build_world(Scenario(name="cache", duration=1.0, friction=0.61))
    alive = weakref.ref(world)
    assert pinocchio_for(world).model.nq == world.model.nq
    world_module._WORLDS.clear()  # as when eight newer worlds have evicted it
    del world
    gc.collect()
    assert alive() is not None
