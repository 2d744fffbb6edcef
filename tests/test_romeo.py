"""Romeo from its card alone: COLLADA meshes, the card's inertia fix, the SRDF's extra joints, a
drop through `fallbench run sweep`. Standing, the sensors and the Pinocchio-MuJoCo agreement are the
tests parametrised over every robot (tests/test_physics.py, tests/test_model_agreement.py)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from fallbench.robots import get_robot, load_card
from fallbench.robots.description import read_srdf_postures
from fallbench.robots.meshes import converted_meshes
from fallbench.yamlfile import InputError

CARD = Path(__file__).resolve().parents[1] / "fallbench/robots/cards/romeo.yaml"
DROP = """name: romeo_drop
robot: romeo
duration: 1.5
initial: {posture: default, height: 0.1}
"""


def _inertia(urdf: str, link: str) -> dict[str, float]:
    element = ET.fromstring(urdf).find(f"link[@name='{link}']/inertial/inertia")
    assert element is not None
    return {key: float(value) for key, value in element.attrib.items()}


def test_the_card_mirrors_the_left_arm_inertias_onto_the_right() -> None:
    robot = get_robot("romeo")
    shipped, fixed = robot.urdf_path.read_text(), robot.urdf_text()
    for right, left in (("RShoulderYawLink", "LShoulderYawLink"), ("RElbowYawLink", "LElbowYawLink")):
        assert _inertia(shipped, right)["izz"] == pytest.approx(_inertia(shipped, left)["izz"] / 10, rel=0.01)
        mirrored = {k: -v if k in ("ixy", "iyz") else v for k, v in _inertia(shipped, left).items()}
        assert _inertia(fixed, right) == mirrored
    assert robot.mass == pytest.approx(40.529, abs=1e-3)
    assert len(fixed.splitlines()) == len(shipped.splitlines())  # the two elements alone change


def test_srdf_joints_the_urdf_lacks_are_dropped() -> None:
    robot = get_robot("romeo")
    srdf = read_srdf_postures(robot.srdf_path)[0]["half_sitting"]
    assert {"LToePitch", "REyeYaw"} <= set(srdf)
    extra = {"LToePitch", "RToePitch", "LEyeYaw", "REyeYaw", "LEyePitch", "REyePitch"}
    assert robot.postures["default"] == {joint: value for joint, value in srdf.items() if joint not in extra}
    assert not {"LToePitch", "RToePitch", "LEyeYaw", "REyeYaw", "LEyePitch", "REyePitch"} & set(
        robot.postures["default"]
    )
    assert robot.postures["default"]["RKneePitch"] == pytest.approx(0.6981317)


def test_its_collada_meshes_are_converted() -> None:
    meshes = converted_meshes(get_robot("romeo"))
    assert len(meshes) == 40 and len({m.sha256 for m in meshes}) == 21  # visual and collision copies
    assert all(m.source.suffix == ".dae" and m.target.is_file() for m in meshes)


def test_robots_check_names_the_converted_meshes() -> None:
    from fallbench.results.robot_check import mesh_lines

    romeo = mesh_lines(get_robot("romeo"))
    assert romeo[0].startswith("meshes: 40 COLLADA files converted to STL")  # visual and collision
    assert len(romeo) == 41 and all(line.endswith(".stl") for line in romeo[1:])
    assert mesh_lines(get_robot("talos")) == [
        "meshes: none converted (MuJoCo reads the URDF's meshes as they are)"
    ]


def test_a_non_physical_inertia_override_is_named(tmp_path: Path) -> None:
    card = tmp_path / "romeo.yaml"
    card.write_text(CARD.read_text().replace("izz: 0.00211065", "izz: 0.02"))
    with pytest.raises(InputError, match=r"inertia_overrides\.RElbowYawLink: not a rigid body's inertia"):
        load_card(card)
    card.write_text(CARD.read_text().replace("RElbowYawLink: {", "RElbowYawLnk: {"))
    with pytest.raises(InputError, match=r"inertia_overrides\.RElbowYawLnk: no body 'RElbowYawLnk'"):
        load_card(card)


@pytest.mark.slow
def test_a_drop_runs_through_the_sweep_and_is_stored(tmp_path: Path, sweep) -> None:
    from fallbench.results.store import load_metrics

    path = tmp_path / "romeo.yaml"
    path.write_text(DROP)
    result = sweep(path, tmp_path / "r", policies="stiff")
    assert result.exit_code == 0, result.output
    table = load_metrics(tmp_path / "r")
    assert len(table) == 1 and table.status.iloc[0] == "ok" and table.robot.iloc[0] == "romeo"
    assert not table.fell.iloc[0]  # Romeo stays up from 0.1 m (it falls from 0.17 m and more)
    assert np.isfinite(table.imu_peak_z.iloc[0])
