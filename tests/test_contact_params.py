"""The scenario's `contact:` parameters reach MuJoCo's contacts and joint stops, and unsafe ones are refused."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from pydantic import ValidationError

from fallbench.scenario import Scenario
from fallbench.sim.world import build_world, initial_state


def _first_contacts(scenario: Scenario) -> mujoco.MjData:
    world = build_world(scenario)
    data = initial_state(world, scenario)
    while data.ncon == 0 and data.time < 0.3:
        mujoco.mj_step(world.model, data)
    assert data.ncon > 0, "the feet never touched"
    return world, data


@pytest.mark.parametrize(
    "contact, solref",
    [({}, (0.0125, 1.0)), ({"time_constant": 0.04, "damping_ratio": 0.7}, (0.04, 0.7))],
)
def test_robot_floor_contacts_have_the_scenario_softness(contact: dict, solref: tuple) -> None:
    scenario = Scenario(name="drop", duration=0.3, initial={"height": 0.05}, contact=contact)
    world, data = _first_contacts(scenario)
    floor = world.model.geom("floor").id
    for i in range(data.ncon):
        assert floor in (data.contact[i].geom1, data.contact[i].geom2)
        np.testing.assert_allclose(data.contact[i].solref, solref)
        np.testing.assert_allclose(data.contact[i].solimp[:3], scenario.contact.impedance)


def test_joint_stops_have_the_scenario_softness() -> None:
    scenario = Scenario(name="drop", duration=0.3, contact={"stop_time_constant": 0.02})
    model = build_world(scenario).model
    hinges = model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
    np.testing.assert_allclose(model.jnt_solref[hinges], np.tile([0.02, 1.0], (hinges.sum(), 1)))


def test_a_contact_faster_than_two_steps_is_refused() -> None:
    with pytest.raises(ValidationError, match="exceed contact.time_constant"):
        Scenario(name="drop", duration=0.3, physics_dt=0.001, contact={"time_constant": 0.0015})
