"""Pinocchio's model terms agree with MuJoCo's after the joint map (same URDF, same armature)."""

from __future__ import annotations

import numpy as np
import pytest

from fallbench.dynamics.model import build_pinocchio, pinocchio_for
from fallbench.results.robot_check import (
    BIAS_TOLERANCE,
    MASS_MATRIX_TOLERANCE,
    agreement,
    random_state,
)
from fallbench.robots import ROBOTS
from fallbench.scenario import Scenario
from fallbench.sim import world as world_module


@pytest.mark.parametrize("robot", ROBOTS)
def test_mass_matrix_and_nonlinear_effects_agree(robot: str) -> None:
    """At random states (the check of `fallbench robots check`)."""
    terms = agreement(robot)
    assert terms.mass_matrix < MASS_MATRIX_TOLERANCE and terms.bias < BIAS_TOLERANCE
    assert terms.problems() == []


@pytest.mark.parametrize("robot", ROBOTS)
def test_armature_is_in_both_models(robot: str) -> None:
    world, _ = random_state(robot, 0)
    P = build_pinocchio(world)
    joints = [world.joint_names.index(j) for j in world.robot.armature]
    assert joints, "every registered robot declares its rotor inertias"
    np.testing.assert_allclose(
        world.model.dof_armature[world.qvel_adr[joints]], list(world.robot.armature.values())
    )
    np.testing.assert_allclose(P.model.armature[P.actuated_v], world.model.dof_armature[world.qvel_adr])
    if robot == "talos":  # the SRDF's rotor_params: 1e-5 kg m^2 x gear ratio 100^2
        np.testing.assert_allclose(world.model.dof_armature[world.qvel_adr[joints]], 0.1)


def test_the_pinocchio_model_is_keyed_by_the_robot_not_the_world_object() -> None:
    """Every world of a robot shares its Pinocchio model, however many world objects runs made; another
    robot gets its own (keyed by object identity, a freed world's id once gave G1 drops TALOS's model)."""
    talos = [
        world_module.build_world(Scenario(name="cache", duration=1.0, friction=friction))
        for friction in (0.61, 0.61, 0.9)
    ]
    assert talos[0] is not talos[1] and talos[0].model is not talos[1].model  # a run's own model
    assert len({id(pinocchio_for(world)) for world in talos}) == 1
    g1 = world_module.build_world(Scenario(name="cache", duration=1.0, robot="g1"))
    assert pinocchio_for(g1) is not pinocchio_for(talos[0])
    assert pinocchio_for(g1).model.nq == g1.model.nq
