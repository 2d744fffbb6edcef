"""COLLADA (.dae) meshes of a URDF, converted once to STL, the format MuJoCo reads, and every
mesh path made absolute.

Many ROS description packages ship their meshes as COLLADA (Romeo's in example-robot-data), which
MuJoCo cannot read. `mujoco_urdf_text` gives a robot's URDF with every `.dae` that a <mesh> names
replaced by an STL file converted from it: the first time with trimesh (whose COLLADA reader is
pycollada), afterwards from a cache keyed by the source file's sha256, so a changed mesh is
converted again and an unchanged one never is. Meshes MuJoCo reads already are left as they are,
but a relative path (or a file:// URI) is made absolute from the URDF's folder, as ROS reads it:
MuJoCo reads the URDF from a string, which has no folder of its own.

COLLADA is a large format (scene graphs of nodes with their own transforms, units, up axes,
several primitive kinds); a maintained reader handles what the description packages actually
contain rather than the subset a hand-written one would guess. What the STL holds, in the mesh's
own frame as the URDF uses it:

- the scene graph baked in: every node's transform applied (Romeo's vertices are centimetres
  under a node <scale> of 0.01);
- `<unit meter>` applied, as Gazebo and RViz do (trimesh records it without applying it);
- `<up_axis>` ignored, as RViz and MoveIt do: URDF meshes are authored against RViz.

The cache folder is `$FALLBENCH_CACHE` if set, else `meshes/` in fallbench's user cache
(`$XDG_CACHE_HOME/fallbench`, by default `~/.cache/fallbench`, beside the compiled worlds).
A mesh that cannot be read is a `MeshError`, one line naming the file.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fallbench.robots.cache import cache_root

if TYPE_CHECKING:
    from fallbench.robots.description import RobotDescription

CONVERTER_VERSION = 1  # part of the cache file names: bump when the conversion itself changes
CONVERTED_SUFFIXES = (".dae",)  # mesh files MuJoCo cannot read, which this module converts
CACHE_ENV = "FALLBENCH_CACHE"
FILENAME = re.compile(r"""filename=(["'])(.*?)\1""")


class MeshError(ValueError):
    """A mesh that cannot be read or converted; the message is one line naming the file."""


@dataclass(frozen=True)
class ConvertedMesh:
    """One COLLADA file and the STL made from it."""

    source: Path
    target: Path  # the STL in the cache
    sha256: str  # of the source file
    cached: bool  # the STL was in the cache already


def cache_dir() -> Path:
    """Where converted meshes are kept."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    return cache_root() / "meshes"


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_collada(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (m) and triangles of every geometry in a COLLADA file's scene."""
    import collada  # pycollada, for <unit>, which trimesh records but does not apply
    import trimesh

    try:
        mesh = trimesh.load_scene(str(path), file_type="dae").to_mesh()  # node transforms baked in
        unit = collada.Collada(str(path), ignore=[collada.common.DaeUnsupportedError]).assetInfo.unitmeter
    except Exception as error:  # any reader failure is reported the same way: one line, the file
        message = " ".join(str(error).split()) or type(error).__name__
        raise MeshError(f"{path}: cannot read COLLADA mesh: {type(error).__name__}: {message}") from None
    if len(mesh.faces) == 0:
        raise MeshError(f"{path}: COLLADA mesh holds no triangles")
    vertices = np.asarray(mesh.vertices, dtype=float) * float(unit or 1.0)
    if not np.isfinite(vertices).all():
        raise MeshError(f"{path}: COLLADA mesh has non-finite vertices")
    return vertices, np.asarray(mesh.faces, dtype=np.int64)


def convert_mesh(source: Path, folder: Path) -> ConvertedMesh:
    """The STL of one COLLADA file, converted unless the cache holds it."""
    import trimesh

    if not source.is_file():
        raise MeshError(f"{source}: mesh file not found")
    sha = _sha256(source)
    target = folder / f"{sha}-v{CONVERTER_VERSION}.stl"
    if target.is_file():
        return ConvertedMesh(source, target, sha, cached=True)
    vertices, faces = read_collada(source)
    stl = trimesh.Trimesh(vertices=vertices, faces=faces, process=False).export(file_type="stl")
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".stl.tmp")
    with os.fdopen(fd, "wb") as stream:
        stream.write(stl)
    os.replace(tmp, target)  # workers converting the same file at once write the same bytes
    return ConvertedMesh(source, target, sha, cached=False)


def mesh_names(urdf_text: str) -> list[str]:
    """The distinct <mesh filename> values of a URDF, sorted."""
    return sorted(
        {m.attrib["filename"] for m in ET.fromstring(urdf_text).iter("mesh") if "filename" in m.attrib}
    )


def mesh_file(name: str, base_dir: Path) -> Path:
    """The file a <mesh filename> names: a path (absolute, or relative to `base_dir`, the URDF's
    folder) or a file:// URI; MeshError for a package URI (resolve those first)."""
    if name.startswith("package://"):
        raise MeshError(f"{name}: unresolved package URI")
    return (base_dir / name.removeprefix("file://")).resolve()


def convert_urdf_meshes(
    urdf_text: str, base_dir: Path, folder: Path | None = None
) -> tuple[str, tuple[ConvertedMesh, ...]]:
    """`urdf_text` with each COLLADA <mesh filename> replaced by its STL's absolute path, each
    other relative path or file:// URI by the file's absolute path, and the converted meshes (one
    per distinct file). Relative filenames are relative to `base_dir`; package URIs must be
    resolved before. Only those filename attributes change: every other byte of the text (an
    absolute path too) stays as it was."""
    folder = (folder or cache_dir()).resolve()
    by_name: dict[str, ConvertedMesh] = {}
    by_source: dict[Path, ConvertedMesh] = {}
    names = set(mesh_names(urdf_text))
    for name in sorted(names):
        if not name.lower().endswith(CONVERTED_SUFFIXES):
            continue
        source = mesh_file(name, base_dir)
        if source not in by_source:
            by_source[source] = convert_mesh(source, folder)
        by_name[name] = by_source[source]

    def replace(match: re.Match[str]) -> str:
        quote, name = match.group(1), match.group(2)
        mesh = by_name.get(name)
        if mesh is not None:
            return f"filename={quote}{mesh.target}{quote}"
        if name not in names or name.startswith("package://") or Path(name).is_absolute():
            return match.group(0)  # not a mesh (e.g. a <gazebo> plugin), or nothing to resolve
        return f"filename={quote}{mesh_file(name, base_dir)}{quote}"

    return FILENAME.sub(replace, urdf_text), tuple(by_source.values())


def converted_meshes(robot: RobotDescription) -> tuple[ConvertedMesh, ...]:
    """The robot's COLLADA meshes and their STLs (converting those not cached yet); empty for a
    robot whose meshes MuJoCo reads as they are, and for an MJCF (which MuJoCo reads as it is)."""
    if robot.urdf_path is None:
        return ()
    return convert_urdf_meshes(robot.urdf_text(), robot.urdf_path.parent)[1]


def mujoco_urdf_text(robot: RobotDescription) -> str:
    """The robot's URDF as MuJoCo reads it: package URIs resolved, COLLADA meshes as STL."""
    return convert_urdf_meshes(robot.urdf_text(), robot.model_path.parent)[0]
