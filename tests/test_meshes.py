"""COLLADA meshes converted to STL once (fallbench/robots/meshes.py), on a tiny synthetic file."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from fallbench.robots.meshes import MeshError, convert_mesh, convert_urdf_meshes, read_collada

# One triangle in millimetres (<unit meter="0.001">) under a node scaling it by 2.
DAE = """<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><unit meter="0.001" name="millimeter"/><up_axis>Z_UP</up_axis></asset>
<library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="pa" count="12">0 0 0 50 0 0 0 50 0 0 0 50</float_array>
<technique_common><accessor source="#pa" count="4" stride="3"><param name="X" type="float"/>
<param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/><p>0 2 1 0 1 3 0 3 2 1 2 3</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s"><node id="n"><scale>2 2 2</scale><instance_geometry url="#g"/>
</node></visual_scene></library_visual_scenes><scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""

URDF = """<robot name="r">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <visual><geometry><mesh filename="meshes/tet.dae"/></geometry></visual>
    <collision><geometry><mesh filename="meshes/tet.dae" scale="1 1 1"/></geometry></collision>
  </link>
</robot>
"""


@pytest.fixture
def mesh_folder(tmp_path: Path) -> Path:
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tet.dae").write_text(DAE)
    return tmp_path


def test_units_and_node_transforms_are_applied(mesh_folder: Path) -> None:
    vertices, faces = read_collada(mesh_folder / "meshes" / "tet.dae")
    assert len(faces) == 4
    np.testing.assert_allclose(vertices.max(axis=0), [0.1, 0.1, 0.1])  # 50 mm x 2 = 0.1 m


def test_converted_once_then_from_the_cache(mesh_folder: Path, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    text, meshes = convert_urdf_meshes(URDF, mesh_folder, cache)
    assert len(meshes) == 1 and not meshes[0].cached  # two references, one file
    stl = meshes[0].target
    assert stl.parent == cache.resolve() and stl.suffix == ".stl" and meshes[0].sha256 in stl.name
    assert text.count(f'filename="{stl}"') == 2 and ".dae" not in text
    assert text.replace(str(stl), "meshes/tet.dae") == URDF  # nothing else changed
    mtime = stl.stat().st_mtime_ns
    again, meshes = convert_urdf_meshes(URDF, mesh_folder, cache)
    assert again == text and meshes[0].cached and stl.stat().st_mtime_ns == mtime
    model = mujoco.MjModel.from_xml_string(text)  # MuJoCo reads the result
    assert model.nmesh >= 1 and np.abs(model.mesh_vert).max() <= 0.1 + 1e-9  # m, as converted


def test_a_changed_mesh_is_converted_again(mesh_folder: Path, tmp_path: Path) -> None:
    source = mesh_folder / "meshes" / "tet.dae"
    first = convert_mesh(source, tmp_path / "cache")
    source.write_text(DAE.replace("<scale>2 2 2</scale>", "<scale>3 3 3</scale>"))
    second = convert_mesh(source, tmp_path / "cache")
    assert not second.cached and second.target != first.target


@pytest.mark.parametrize(
    "content, reason",
    [
        ('<?xml version="1.0"?><COLLADA><asset></asset', "cannot read COLLADA mesh"),
        ("not xml at all", "cannot read COLLADA mesh"),
        (None, "mesh file not found"),
    ],
)
def test_an_unreadable_mesh_is_one_line_naming_it(
    mesh_folder: Path, tmp_path: Path, content: str | None, reason: str
) -> None:
    source = mesh_folder / "meshes" / "tet.dae"
    if content is None:
        source.unlink()
    else:
        source.write_text(content)
    with pytest.raises(MeshError) as error:
        convert_urdf_meshes(URDF, mesh_folder, tmp_path / "cache")
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"{source.resolve()}: {reason}")
    assert not (tmp_path / "cache").exists() or not list((tmp_path / "cache").iterdir())


def test_meshes_mujoco_reads_are_not_converted_and_relative_paths_made_absolute(tmp_path: Path) -> None:
    """MuJoCo reads the URDF from a string: a path relative to the URDF's folder (or a file:// URI)
    must reach it absolute; absolute paths, other attributes and the rest of the text stay."""
    urdf = URDF.replace("meshes/tet.dae", "meshes/tet.stl", 1).replace(
        "meshes/tet.dae", "file:///abs/tet.stl"
    )
    urdf = urdf.replace("</robot>", '<gazebo><plugin filename="libplugin.so"/></gazebo>\n</robot>')
    text, converted = convert_urdf_meshes(urdf, tmp_path, tmp_path / "cache")
    assert not converted
    assert text == urdf.replace("meshes/tet.stl", f"{tmp_path.resolve()}/meshes/tet.stl").replace(
        "file:///abs/tet.stl", "/abs/tet.stl"
    )
    absolute = URDF.replace("meshes/tet.dae", "/abs/tet.stl")
    assert convert_urdf_meshes(absolute, tmp_path, tmp_path / "cache") == (absolute, ())
