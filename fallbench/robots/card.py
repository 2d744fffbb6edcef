"""Robot cards: a robot as a YAML file and its URDF or MJCF, with no Python.

A card names the model files (a URDF or an MJCF, optionally an SRDF) and declares what the model
does not say: which bodies are the root, the torso and the IMU, which bodies count as feet, knees,
hands ..., the leg and arm chains, the default gains, the nominal stance and its standing height.
`load_card` checks the card against the model (every named body and joint exists, every pattern
matches, every actuated joint has gains) and builds the `RobotDescription` the rest of fallbench
reads. What the files give is derived: the mass and the joint limits from the URDF or MJCF; named
postures (and the root height in them), disabled collision pairs and rotor inertias from the SRDF,
and from an MJCF's own keyframes, contact excludes and joint armature (fallbench/robots/mjcf.py).
The format, key by key: docs/robots.md.
"""

from __future__ import annotations

import hashlib
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, distribution, version
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError
from ruamel.yaml.comments import CommentedMap

from fallbench.robots.card_schema import BodyGroups, Gains, LegPitch, RobotCard
from fallbench.robots.description import (
    DEFAULT_POSTURE,
    INERTIA_KEYS,
    SIDES,
    Arm,
    GainGroup,
    RobotDescription,
    link_block,
    read_srdf_armature,
    read_srdf_disabled_collisions,
    read_srdf_postures,
    resolve_package_uris,
)
from fallbench.robots.meshes import MeshError, mesh_file, mesh_names
from fallbench.robots.mjcf import MjcfError, MjcfModel, keyframe_postures, pinocchio_problem, read_mjcf
from fallbench.yamlfile import InputError, line_of, plain, read_yaml, validation_error

KIND = "robot card"  # how messages name the file
ACTUATED = ("revolute", "continuous", "hinge")  # joint types that get a servo (URDF's, MJCF's hinge)
# RobotDescription fields whose card key has another name
CARD_KEYS = {"gain_groups": "gains", "learned_gain_groups": "learned_gains"}


@dataclass(frozen=True)
class ModelNames:
    """The names a card may use: the model's links (bodies), and its joints with their types (the
    URDF's, or the MJCF's kinds), in file order."""

    links: tuple[str, ...]
    joints: dict[str, str]  # name -> type

    @property
    def actuated(self) -> tuple[str, ...]:
        return tuple(name for name, kind in self.joints.items() if kind in ACTUATED)


def rpy_quaternion(rpy: tuple[float, float, float]) -> tuple[float, float, float, float]:
    """(w, x, y, z) of the URDF's roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, sr), (cp, sp), (cy, sy) = ((np.cos(a / 2), np.sin(a / 2)) for a in rpy)
    return (
        float(cr * cp * cy + sr * sp * sy),
        float(sr * cp * cy - cr * sp * sy),
        float(cr * sp * cy + sr * cp * sy),
        float(cr * cp * sy - sr * sp * cy),
    )


def card_key(field: str) -> str:
    """The card key that fills a RobotDescription field."""
    return CARD_KEYS.get(field, field)


def read_urdf(path: Path) -> ModelNames:
    """Link and joint names of a URDF file (ET.ParseError on malformed XML)."""
    root = ET.parse(path).getroot()
    links = tuple(link.attrib["name"] for link in root.findall("link"))
    joints = {joint.attrib["name"]: joint.attrib.get("type", "") for joint in root.findall("joint")}
    return ModelNames(links, joints)


def load_card(path: Path) -> RobotDescription:
    """The robot of a card file; InputError (file, line, key, reason) on any problem."""
    docs = read_yaml(path, KIND)
    if len(docs) > 1:
        raise InputError(path, docs[1].lc.line + 1, "", "a robot card holds one YAML document")
    doc = docs[0]
    try:
        card = RobotCard.model_validate(plain(doc))
    except ValidationError as exc:
        raise validation_error(path, doc, exc) from None
    return CardReader(path, doc, card).description()


class CardReader:
    """A validated card checked against its URDF or MJCF, one problem at a time, each at its line."""

    def __init__(self, path: Path, doc: CommentedMap, card: RobotCard) -> None:
        self.path, self.doc, self.card = path, doc, card
        model = card.model
        if (model.urdf is None) == (model.mjcf is None):
            raise self.error(("model",), "give the robot's model as either `urdf` or `mjcf`, one of the two")
        self.root, self.version = self._model_root()
        self.model_key = "urdf" if model.urdf is not None else "mjcf"  # the card key of the model file
        self.model_path = self._file(self.model_key, model.urdf or model.mjcf or "")
        self.srdf_path = self._file("srdf", model.srdf) if model.srdf else None
        self.keyframes_path = self._file("keyframes", model.keyframes) if model.keyframes else None
        self.mjcf: MjcfModel | None = None
        if model.urdf is not None:
            try:
                self.known = read_urdf(self.model_path)
            except ET.ParseError as exc:
                raise self.error(("model", "urdf"), f"not a readable URDF ({exc})") from None
        else:
            self.mjcf = self._read_mjcf()
            self.known = ModelNames(self.mjcf.links, self.mjcf.joints)
        if not self.known.actuated:
            kinds = "revolute or continuous joint" if self.mjcf is None else "hinge joint"
            raise self.error(
                ("model", self.model_key),
                f"{self.model_path.name} has no {kinds}: nothing for a servo to drive",
            )

    def _read_mjcf(self) -> MjcfModel:
        """The MJCF's robot: its worldbody holds the root body alone (a floor, lights beside it),
        and Pinocchio reads the same joints from it as MuJoCo."""
        loc = ("model", "mjcf")
        try:
            mjcf = read_mjcf(self.model_path)
        except MjcfError as exc:
            raise self.error(loc, str(exc)) from None
        name = self.model_path.name
        if len(mjcf.top_bodies) != 1:
            raise self.error(
                loc, f"{name}'s worldbody holds {len(mjcf.top_bodies)} bodies, not one: the robot alone"
            )
        if self.card.root_body != mjcf.top_bodies[0]:
            raise self.error(
                ("root_body",), f"{self.card.root_body!r} is not {name}'s top body ({mjcf.top_bodies[0]!r})"
            )
        problem = pinocchio_problem(self.model_path, mjcf.joints)
        if problem:
            raise self.error(loc, problem)
        return mjcf

    def error(self, loc: tuple[Any, ...], reason: str) -> InputError:
        """The problem at `loc` (keys and list indices), at its line in the card."""
        return InputError(self.path, line_of(self.doc, loc), ".".join(map(str, loc)), reason)

    def _model_root(self) -> tuple[Path, str]:
        """The folder the model paths are relative to, and the version of the package holding it."""
        model = self.card.model
        if model.package is None:
            return (self.path.parent / model.root).resolve(), "local files"
        try:
            found = distribution(model.package)
        except PackageNotFoundError:
            raise self.error(("model", "package"), f"no installed package {model.package!r}") from None
        return Path(str(found.locate_file(model.root))), f"{model.package} {version(model.package)}"

    def _file(self, key: str, relative: str) -> Path:
        path = self.root / relative
        if not path.is_file():
            raise self.error(("model", key), f"no file {path}")
        return path

    def names(self, loc: tuple[Any, ...], names: tuple[str, ...], known: tuple[str, ...], what: str) -> None:
        """Every name of `names` is one of `known` (the URDF's links or joints)."""
        for index, name in enumerate(names):
            if name not in known:
                where = loc + (index,) if len(names) > 1 else loc
                raise self.error(where, f"no {what} {name!r} in {self.model_path.name}")

    def matches(
        self, loc: tuple[Any, ...], pattern: str, known: tuple[str, ...], what: str
    ) -> tuple[str, ...]:
        """`known` names that `pattern` (a name or a regular expression) matches whole, in file order."""
        if pattern in known:
            return (pattern,)
        try:
            found = tuple(name for name in known if re.fullmatch(pattern, name))
        except re.error as exc:
            raise self.error(
                loc, f"{pattern!r} is neither a {what} nor a regular expression ({exc})"
            ) from None
        if not found:
            raise self.error(loc, f"{pattern!r} matches no {what} of {self.model_path.name}")
        return found

    def bodies(self, loc: tuple[Any, ...], entries: tuple[str, ...]) -> tuple[str, ...]:
        """The links that a list of names and regexes gives, in the list's order."""
        found = (self.matches(loc + (i,), entry, self.known.links, "body") for i, entry in enumerate(entries))
        return tuple(dict.fromkeys(body for bodies in found for body in bodies))

    def description(self) -> RobotDescription:
        """The robot description the card gives, every name checked and every pattern expanded."""
        card = self.card
        self._check_meshes()
        self._check_bodies()
        self._check_joints()
        body_groups = {
            group: self.bodies(("body_groups", group), getattr(card.body_groups, group))
            for group in BodyGroups.model_fields
        }
        postures, heights = self._postures()
        return RobotDescription(
            name=card.name,
            urdf_path=self.model_path if self.mjcf is None else None,
            mjcf_path=None if self.mjcf is None else self.model_path,
            model_mass=None if self.mjcf is None else self.mjcf.mass,
            srdf_path=self.srdf_path,
            mesh_root=self.root,
            package_prefix=card.model.package_uri,
            version=self.version,
            fingerprint=self._fingerprint(),
            card_path=self.path,
            root_body=card.root_body,
            torso_body=card.torso_body,
            imu_body=card.imu_body if card.imu_site is None else card.imu_site.body,
            imu_pose=None
            if card.imu_site is None
            else (card.imu_site.pos, rpy_quaternion(card.imu_site.rpy)),
            gain_groups=self._gains("gains", card.gains),
            learned_gain_groups=self._gains("learned_gains", card.learned_gains),
            body_groups=body_groups,
            legs={side: getattr(card.legs, side) for side in SIDES},
            arms={} if card.arms is None else {side: Arm(**dict(getattr(card.arms, side))) for side in SIDES},
            leg_pitch_joints={
                part: (getattr(card.leg_pitch_joints, part).left, getattr(card.leg_pitch_joints, part).right)
                for part in LegPitch.model_fields
            },
            feet={} if card.feet is None else {side: getattr(card.feet, side) for side in SIDES},
            timeseries_joints=card.timeseries_joints,
            trajectory_joints=card.trajectory_joints,
            vulnerable_parts=self._vulnerable_parts(body_groups),
            torque_chains=self._torque_chains(),
            armature=self._armature(),
            postures=postures,
            posture_base_height=heights,
            standing_height_given=card.standing_height is not None,
            disabled_collisions=self._disabled_collisions(),
            disable_stance_contacts="auto" in card.disabled_collisions,
            inertia_overrides=self._inertia_overrides(),
            torso_axes=(card.torso_axes.forward, card.torso_axes.left, card.torso_axes.up),
        )

    def _check_meshes(self) -> None:
        """Every mesh the URDF names is a file: a package URI resolved into `root` by
        `package_uri`, a relative path from the URDF's folder, or an absolute path. (An MJCF's
        meshes are read as MuJoCo compiled it: a missing one is an error of `model.mjcf`.)"""
        model = self.card.model
        if self.mjcf is not None:
            return
        for name in mesh_names(self.model_path.read_text()):
            try:
                path = mesh_file(
                    resolve_package_uris(name, model.package_uri, self.root), self.model_path.parent
                )
            except MeshError:
                raise self.error(
                    ("model", "package_uri"),
                    f"{self.model_path.name} names mesh {name}, which package_uri "
                    f"{model.package_uri!r} does not resolve: set it to the URI's part "
                    f"before the path inside root ({self.root})",
                ) from None
            if not path.is_file():
                raise self.error(
                    ("model", "urdf"), f"{self.model_path.name} names mesh {name}: no file {path}"
                )

    def _check_bodies(self) -> None:
        card, links = self.card, self.known.links
        for key in ("root_body", "torso_body"):
            self.names((key,), (getattr(card, key),), links, "body")
        if (card.imu_body is None) == (card.imu_site is None):
            raise self.error(("imu_body",), "give the IMU as either `imu_body` or `imu_site`, one of the two")
        if card.imu_site is not None:
            self.names(("imu_site", "body"), (card.imu_site.body,), links, "body")
        else:
            self.names(("imu_body",), (card.imu_body,), links, "body")
        for side in SIDES:
            if card.feet is not None:
                self.names(("feet", side), (getattr(card.feet, side),), links, "body")
            if card.arms is not None:
                arm = getattr(card.arms, side)
                for key in ("wrist_frame", "hand_frame"):
                    self.names(("arms", side, key), (getattr(arm, key),), links, "body")
        for index, pair in enumerate(self._pairs()):
            self.names(("disabled_collisions", index), pair, links, "body")

    def _check_joints(self) -> None:
        card, joints = self.card, self.known.actuated
        for side in SIDES:
            self.names(("legs", side), getattr(card.legs, side), joints, "actuated joint")
            if card.arms is not None:
                arm = getattr(card.arms, side)
                for key in ("shoulder_joint", "elbow_joint", "wrist_joint", "wrist_pitch_joint"):
                    self.names(("arms", side, key), (getattr(arm, key),), joints, "actuated joint")
        for part in LegPitch.model_fields:
            pair = getattr(card.leg_pitch_joints, part)
            for side in SIDES:
                self.names(("leg_pitch_joints", part, side), (getattr(pair, side),), joints, "actuated joint")
        self.names(("timeseries_joints",), card.timeseries_joints, joints, "actuated joint")
        drawn = [*card.trajectory_joints, card.leg_pitch_joints.hip.right, card.leg_pitch_joints.knee.right]
        drawn.append(card.leg_pitch_joints.ankle.right)
        missing = [joint for joint in drawn if joint not in card.timeseries_joints]
        if missing:
            raise self.error(
                ("timeseries_joints",),
                f"misses {', '.join(missing)}: the trajectory joints and the right leg's pitch joints "
                "are drawn from the stored series",
            )

    def _gains(self, key: str, gains: dict[str, Gains]) -> tuple[GainGroup, ...]:
        """Gain groups in the card's order; when any are given, every actuated joint must match one."""
        groups = tuple(GainGroup(pattern, pd.kp, pd.kd) for pattern, pd in gains.items())
        for pattern in gains:
            self.matches((key, pattern), pattern, self.known.actuated, "actuated joint")
        for joint in self.known.actuated if groups else ():
            if not any(re.fullmatch(group.pattern, joint) for group in groups):
                raise self.error((key,), f"joint {joint!r} matches none of the patterns")
        return groups

    def _vulnerable_parts(self, body_groups: dict[str, tuple[str, ...]]) -> dict[str, tuple[str, ...]]:
        """Part -> bodies; each body must be in a body group (those alone have contact sensors)."""
        sensed = {body for bodies in body_groups.values() for body in bodies}
        parts = {}
        for part, entries in self.card.vulnerable_parts.items():
            parts[part] = self.bodies(("vulnerable_parts", part), entries)
            outside = [body for body in parts[part] if body not in sensed]
            if outside:
                raise self.error(("vulnerable_parts", part), f"{', '.join(outside)} in no body group")
        return parts

    def _torque_chains(self) -> dict[str, str]:
        for chain, pattern in self.card.torque_chains.items():
            self.matches(("torque_chains", chain), pattern, self.known.actuated, "actuated joint")
        return dict(self.card.torque_chains)

    def _armature(self) -> dict[str, float]:
        """Joint -> kg m^2: an MJCF's joint armature, the SRDF's rotor parameters over it, then the
        card's entries over them."""
        armature = {} if self.mjcf is None else dict(self.mjcf.armature)
        armature.update(read_srdf_armature(self.srdf_path) if self.srdf_path else {})
        for key, value in self.card.armature.items():
            for joint in self.matches(("armature", key), key, self.known.actuated, "actuated joint"):
                armature[joint] = value
        return armature

    def _postures(self) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
        """Named postures (the SRDF's group states, an MJCF's keyframes, those of `keyframes`, then the
        card's) with `default`, and the root height standing in them (m): the SRDF's or the keyframe's
        where it gives one, `standing_height` for `default` (left out when the card does not give it)."""
        postures, heights = read_srdf_postures(self.srdf_path) if self.srdf_path else ({}, {})
        # An SRDF is often shared by a full model and a reduced one (fingers, toes, eyes left out):
        # its group states' joints that the URDF lacks are dropped
        actuated = set(self.known.actuated)
        postures = {
            name: {j: v for j, v in joints.items() if j in actuated} for name, joints in postures.items()
        }
        if self.mjcf is not None:
            postures.update(self.mjcf.postures)
            heights.update(self.mjcf.heights)
        if self.keyframes_path is not None:
            keys, key_heights = self._keyframes(self.keyframes_path, actuated)
            postures.update(keys)
            heights.update(key_heights)
        for name, joints in self.card.postures.items():
            for joint in joints:
                self.names(("postures", name, joint), (joint,), self.known.actuated, "actuated joint")
            postures[name] = dict(joints)
        chosen = self.card.default_posture
        if chosen is not None:
            if chosen not in postures:
                raise self.error(
                    ("default_posture",), f"no posture {chosen!r} (known: {', '.join(postures)})"
                )
            postures[DEFAULT_POSTURE] = postures[chosen]
        if DEFAULT_POSTURE not in postures:
            raise self.error(
                ("postures",), f"no posture {DEFAULT_POSTURE!r} (the nominal stance) nor `default_posture`"
            )
        if self.card.standing_height is not None:  # else derived by settling (fallbench/sim/settle.py)
            heights[DEFAULT_POSTURE] = self.card.standing_height
        return postures, heights

    def _keyframes(
        self, path: Path, actuated: set[str]
    ) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
        """The named keyframes of the MJCF `model.keyframes` (as MuJoCo compiles it): posture name ->
        the values of its hinge joints that are actuated joints of the model, and the height of its
        free joint (the root) where it has one."""
        import mujoco

        loc = ("model", "keyframes")
        try:
            model = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as exc:
            raise self.error(loc, f"MuJoCo cannot read {path.name}: {' '.join(str(exc).split())}") from None
        postures, heights = keyframe_postures(model, actuated)
        for name, joints in postures.items():
            if not joints:
                raise self.error(loc, f"keyframe {name!r} sets no actuated joint of {self.model_path.name}")
        if not postures:
            raise self.error(loc, f"{path.name} has no named keyframe")
        return postures, heights

    def _inertia_overrides(self) -> dict[str, tuple[float, ...]]:
        """Link -> tensor; each link has an <inertia> to replace, each tensor is a physical one
        (positive principal moments that satisfy the triangle inequality)."""
        overrides: dict[str, tuple[float, ...]] = {}
        if self.mjcf is not None and self.card.inertia_overrides:
            raise self.error(
                ("inertia_overrides",),
                "replaces a URDF's <inertia>: in an MJCF, fix the body's <inertial> (Pinocchio reads the file)",
            )
        text = "" if self.mjcf is not None else self.model_path.read_text()
        for link, inertia in self.card.inertia_overrides.items():
            loc = ("inertia_overrides", link)
            self.names(loc, (link,), self.known.links, "body")
            block = link_block(text, link)
            if block is None or "<inertia" not in block.group(0):
                raise self.error(loc, f"link {link!r} has no <inertia> in {self.model_path.name}")
            tensor = tuple(getattr(inertia, key) for key in INERTIA_KEYS)
            xx, xy, xz, yy, yz, zz = tensor
            moments = np.linalg.eigvalsh([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            if moments[0] <= 0 or moments[0] + moments[1] < moments[2]:
                raise self.error(loc, f"not a rigid body's inertia (principal moments {moments.round(9)})")
            overrides[link] = tensor
        return overrides

    def _pairs(self) -> tuple[tuple[str, str], ...]:
        """The card's disabled pairs (`auto` left out)."""
        entries = self.card.disabled_collisions
        return () if entries == "auto" else tuple(pair for pair in entries if pair != "auto")

    def _disabled_collisions(self) -> tuple[tuple[str, str], ...]:
        """The SRDF's disabled pairs, an MJCF's contact excludes, then the card's."""
        srdf = read_srdf_disabled_collisions(self.srdf_path) if self.srdf_path else ()
        return srdf + (() if self.mjcf is None else self.mjcf.excludes) + self._pairs()

    def _fingerprint(self) -> str:
        """Hash of the card and the model files: part of every run's identity."""
        digest = hashlib.sha256(self.path.read_bytes() + self.model_path.read_bytes())
        if self.srdf_path is not None:
            digest.update(self.srdf_path.read_bytes())
        if self.keyframes_path is not None:
            digest.update(self.keyframes_path.read_bytes())
        return digest.hexdigest()[:16]
