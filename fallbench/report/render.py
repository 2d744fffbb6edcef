"""Falls rendered with MuJoCo's own renderer, offscreen: filmstrips of a run's key moments and
videos of one run or two side by side, replayed from the qpos the time series keeps at 100 Hz.

Rendering needs an OpenGL context: on Linux fallbench asks MuJoCo for EGL (headless) unless
MUJOCO_GL says otherwise. Without one, `RenderUnavailable` carries a one-line reason.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from ruamel.yaml import YAML

from fallbench.report.grouping import named_point
from fallbench.report.names import arm_name
from fallbench.results import store
from fallbench.scenario import Scenario

FRAME_SIZE = (320, 266)  # px, width x height of one filmstrip frame
VIDEO_SIZE = (640, 480)  # px per run in a video
CAMERA_ELEVATION = -12.0  # deg, slightly from above so the floor and the obstacles show
MERGE_WINDOW = 0.02  # s: key moments closer than this share a frame
AZIMUTH_TURNS = (0, 180, 45, -45, 135, -135, 90, -90)  # deg from across the fall: the views tried, in order
OCCLUSION_SAMPLES = 12  # poses of a replay checked for a hidden robot
STRIP_COLUMNS = 4  # frames per filmstrip row: 4 x 320 px fit a page at their size


class RenderUnavailable(RuntimeError):
    """No OpenGL context for offscreen rendering."""


class ReplayMissing(ValueError):
    """The run is not in the store or has no replay columns."""


@dataclass
class Replay:
    run_id: str
    scenario: Scenario
    label: str  # pre-impact strategy + policy, point
    time: np.ndarray  # s, (samples,)
    qpos: np.ndarray  # (samples, nq)
    row: pd.Series  # the run's metric row


def find_run(results: Path, run_id: str) -> str:
    """A run id, or a prefix of exactly one stored run id."""
    folder = results / store.RUNS
    if (folder / run_id).is_dir():
        return run_id
    matches = (
        sorted(p.name for p in folder.glob(f"{run_id}*") if p.is_dir() and not p.name.startswith("."))
        if folder.is_dir()
        else []
    )
    if len(matches) != 1:
        found = "no stored run" if not matches else f"{len(matches)} stored runs"
        raise ReplayMissing(
            f"{results}: {found} with id {run_id!r} (see `fallbench results --columns run_id,point,policy,pre_impact`)"
        )
    return matches[0]


def load_replay(results: Path, run_id: str) -> Replay:
    run_id = find_run(results, run_id)
    folder = store.run_dir(results, run_id)
    spec = YAML(typ="safe", pure=True).load((folder / "spec.yaml").read_text())
    try:
        series = store.load_timeseries(results, run_id)
    except store.SeriesMissing as exc:
        raise ReplayMissing(f"{exc}: run it again with --timeseries landing or full to render it") from None
    columns = sorted((c for c in series.columns if c.startswith("qpos:")), key=lambda c: int(c.split(":")[1]))
    if not columns:
        raise ReplayMissing(
            f"run {run_id} has no qpos in its time series (stored by an older fallbench): run it again to render it"
        )
    sampled = series[["t", *columns]].dropna()
    row = store.load_run_row(results, run_id)
    point = named_point(str(row.point), str(row.robot)) if isinstance(row.get("robot"), str) else row.point
    label = f"{arm_name(row.pre_impact, row.policy)}, {point}"
    return Replay(
        run_id,
        Scenario.model_validate(spec["scenario"]),
        label,
        sampled.t.to_numpy(float),
        sampled[columns].to_numpy(float),
        row,
    )


def _scene_model(scenario: Scenario, quick: bool = False):
    """The run's scene with a chequered floor, a sky and a larger offscreen buffer (visual only:
    the same bodies and qpos as the simulated model); `quick`: no shadows, no multisampling."""
    import mujoco

    from fallbench.sim.scene import FLOOR_NAME, build_spec

    spec = build_spec(scenario)
    spec.compiler.discardvisual = (
        False  # it would drop the textures below (the URDF's visual meshes are gone already)
    )
    sky = spec.add_texture()
    sky.name, sky.type, sky.builtin = (
        "sky",
        mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
    )
    sky.rgb1, sky.rgb2, sky.width, sky.height = [0.75, 0.85, 0.95], [1.0, 1.0, 1.0], 256, 1536
    grid = spec.add_texture()
    grid.name, grid.type, grid.builtin = (
        "grid",
        mujoco.mjtTexture.mjTEXTURE_2D,
        mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
    )
    grid.rgb1, grid.rgb2, grid.width, grid.height = [0.85, 0.85, 0.85], [0.7, 0.7, 0.72], 512, 512
    material = spec.add_material()
    material.name, material.texrepeat, material.texuniform = "grid", [2.0, 2.0], True
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    for geom in spec.geoms:
        if geom.name == FLOOR_NAME:
            geom.material = "grid"
    buffer = FRAME_SIZE if quick else (2 * VIDEO_SIZE[0], 2 * VIDEO_SIZE[1])  # a filmstrip's frames are small
    spec.visual.global_.offwidth, spec.visual.global_.offheight = buffer
    # A 1024 px shadow map and 2x multisampling: a software (Mesa) renderer draws a frame about
    # twice as fast as with MuJoCo's defaults (4096, 4x), with shadows still showing the contacts.
    # Filmstrips (`quick`) use neither: their small frames draw about 4x faster again (0.05 s
    # instead of 0.22 s per 480 x 400 frame with Mesa's llvmpipe).
    spec.visual.quality.shadowsize, spec.visual.quality.offsamples = (0, 0) if quick else (1024, 2)
    spec.visual.headlight.ambient, spec.visual.headlight.diffuse = [0.35] * 3, [0.55] * 3
    return spec.compile()


@dataclass(frozen=True)
class Framing:
    """A fixed camera for a whole replay: looking across the fall, at the middle of its path."""

    lookat: tuple[float, float, float]
    distance: float
    azimuth: float


def _posed(replay: Replay) -> tuple[Any, Any, np.ndarray]:
    """The replay's scene (model, data) and every 5th of its poses."""
    import mujoco

    from fallbench.sim.world import build_world

    model = build_world(replay.scenario).model
    return model, mujoco.MjData(model), replay.qpos[::5]


def _body_points(replay: Replay) -> np.ndarray:
    """World positions of every robot body over the replay (every 5th sample): what the camera must hold."""
    import mujoco

    model, data, poses = _posed(replay)
    points = []
    for qpos in poses:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        points.append(data.xpos[1:].copy())
    return np.concatenate(points)


def _camera_position(lookat: np.ndarray, distance: float, azimuth: float) -> np.ndarray:
    """Where MuJoCo puts a free camera: `distance` back from `lookat` along its view direction."""
    az, el = math.radians(azimuth), math.radians(CAMERA_ELEVATION)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    return lookat - distance * forward


def _hidden(replay: Replay, eye: np.ndarray) -> int:
    """How many robot bodies, over OCCLUSION_SAMPLES poses of the replay, an obstacle hides from
    `eye`: the ray from the eye to the body meets an obstacle geom (not the robot's, not the
    floor) first."""
    import mujoco

    model, data, poses = _posed(replay)
    robot = model.body_rootid[1]  # the first body is the robot's root, as in `_body_points`
    is_obstacle = (model.body_rootid[model.geom_bodyid] != robot) & (
        model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE
    )
    if not is_obstacle.any():
        return 0
    hidden = 0
    geom = np.zeros(1, dtype=np.int32)
    for qpos in poses[:: max(len(poses) // OCCLUSION_SAMPLES, 1)]:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        for point in data.xpos[1:][model.body_rootid[1:] == robot]:
            fraction = mujoco.mj_ray(model, data, eye, point - eye, None, 1, -1, geom)
            hidden += bool(0 <= fraction < 1 and geom[0] >= 0 and is_obstacle[geom[0]])
    return hidden


def framing(replays: list[Replay]) -> Framing:
    """A side view across the base's path (start to end) that holds every body of the robot over
    the whole replay: standing, in the air and lying. Of the views around it (AZIMUTH_TURNS), the
    first that obstacles hide the least of the robot from."""
    points = np.concatenate([_body_points(r) for r in replays])
    travel = replays[0].qpos[-1, :2] - replays[0].qpos[0, :2]
    # Across the fall direction; a drop (almost no travel) is seen from the robot's front-left.
    azimuth = math.degrees(math.atan2(travel[1], travel[0])) + 90 if np.linalg.norm(travel) > 0.25 else 210.0
    low, high = points.min(axis=0), points.max(axis=0)
    low[2], high[2] = 0.0, high[2] + 0.15  # the floor, and the head's top above its body origin
    centre = (low + high) / 2
    half_fov = math.tan(math.radians(45 / 2))  # MuJoCo's default vertical field of view
    width = float(np.linalg.norm(high[:2] - low[:2]))
    fit = max((high[2] - low[2]) / 2 / half_fov, width / 2 / (half_fov * FRAME_SIZE[0] / FRAME_SIZE[1]))
    distance = 1.1 * fit + 0.5
    best, least = azimuth, None
    for view in (azimuth + turn for turn in AZIMUTH_TURNS):
        hidden = _hidden(replays[0], _camera_position(centre, distance, view))
        if least is None or hidden < least:
            best, least = view, hidden
        if hidden == 0:  # nothing in the way: look no further (most scenes have no obstacle)
            break
    return Framing((float(centre[0]), float(centre[1]), float(centre[2])), distance, best)


class Camera:
    """An offscreen MuJoCo renderer for one scene."""

    def __init__(self, scenario: Scenario, view: Framing, size: tuple[int, int], quick: bool = False) -> None:
        try:
            import mujoco  # MuJoCo loads the MUJOCO_GL backend on import; a missing library fails here
        except Exception as exc:
            raise RenderUnavailable(_gl_reason(exc)) from None

        self.mujoco = mujoco
        self.model = _scene_model(scenario, quick)
        self.data = mujoco.MjData(self.model)
        try:
            with warnings.catch_warnings():  # GLFW warns before it fails; the reason is enough
                warnings.simplefilter("ignore")
                # captions are drawn by Pillow: MuJoCo's smallest font set builds in 0.03 s, not 0.15 s
                self.renderer = mujoco.Renderer(
                    self.model, size[1], size[0], font_scale=mujoco.mjtFontScale.mjFONTSCALE_50
                )
        except (
            Exception
        ) as exc:  # each GL backend fails its own way (ImportError, FatalError, AttributeError)
            raise RenderUnavailable(_gl_reason(exc)) from None
        self.camera = mujoco.MjvCamera()
        self.aim(view)

    def aim(self, view: Framing) -> None:
        self.camera.lookat[:] = view.lookat
        self.camera.distance, self.camera.azimuth, self.camera.elevation = (
            view.distance,
            view.azimuth,
            CAMERA_ELEVATION,
        )

    def frame(self, qpos: np.ndarray) -> np.ndarray:
        self.data.qpos[:] = qpos
        self.mujoco.mj_forward(self.model, self.data)
        self.renderer.update_scene(self.data, self.camera)
        return self.renderer.render().copy()

    def close(self) -> None:
        self.renderer.close()


def _gl_reason(exc: Exception) -> str:
    import os

    backend = os.environ.get("MUJOCO_GL", "")
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return (
        f"no OpenGL context for offscreen rendering (MUJOCO_GL={backend or 'unset'}: {first}); "
        "on a headless Linux machine use MUJOCO_GL=egl with Mesa's EGL installed"
    )


def _at(replay: Replay, t: float) -> np.ndarray:
    """The last replay sample at or before t."""
    return replay.qpos[max(int(np.searchsorted(replay.time, t + 1e-9)) - 1, 0)]


def key_moments(row: pd.Series, end: float) -> list[tuple[float, str]]:
    """(time, caption) of the frames of a filmstrip: fall detection, first impact, each body
    group's first contact, and the end; moments within MERGE_WINDOW share one frame."""
    moments: list[tuple[float, str]] = []
    if pd.notna(row.get("fall_time")):
        moments.append((float(row.fall_time), "fall detected"))
    if pd.notna(row.get("impact_time")):
        moments.append((float(row.impact_time), "first impact"))
    for event in json.loads(row.get("impact_events") or "[]"):
        moments.append((float(event["t"]), f"{event['group']} touch"))
    moments.append((end, "end"))
    merged: list[tuple[float, str]] = []
    for t, caption in sorted(moments, key=lambda m: m[0]):
        if merged and t - merged[-1][0] < MERGE_WINDOW:
            merged[-1] = (merged[-1][0], f"{merged[-1][1]}, {caption}")
        else:
            merged.append((t, caption))
    return merged


_strip_cameras: dict[str, Camera] = {}  # scene -> its renderer, kept for the process's next filmstrips
STRIP_CAMERAS = 2  # renderers a process keeps (creating one takes ~0.25 s with Mesa's llvmpipe)


def scene_key(scenario: Scenario) -> str:
    """Only what a filmstrip shows: the robot and the obstacles. Runs that differ in pushes,
    heights, friction, contact softness, timing or sensors replay on the same picture."""
    drawn = Scenario(name="scene", duration=1.0, robot=scenario.robot, obstacles=scenario.obstacles)
    return drawn.model_dump_json()


def _strip_camera(scenario: Scenario, view: Framing) -> Camera:
    """A quick renderer of the scenario's scene, reused by the filmstrips of the same scene
    (`scene_key`): the last STRIP_CAMERAS scenes of this process keep theirs."""
    key = scene_key(scenario)
    camera = _strip_cameras.pop(key, None)
    if camera is None:
        while len(_strip_cameras) >= STRIP_CAMERAS:
            _strip_cameras.pop(next(iter(_strip_cameras))).close()  # the least recently used
        camera = Camera(scenario, view, FRAME_SIZE, quick=True)
    _strip_cameras[key] = camera
    camera.aim(view)
    return camera


def _strip_image(frames: list[np.ndarray], captions: list[str], title: str) -> np.ndarray:
    """Frames on white in rows of at most STRIP_COLUMNS (a page's width shows their captions at
    their size), each with its caption above it, a title line on top."""
    from PIL import Image, ImageDraw, ImageFont

    width, height = FRAME_SIZE
    top, line = 24, 18
    columns = min(len(frames), STRIP_COLUMNS)
    cell = 2 * line + height
    font, small = ImageFont.load_default(size=16), ImageFont.load_default(size=15)
    rows = -(-len(frames) // columns)
    picture = Image.new("RGB", (width * columns, top + rows * cell), "white")
    draw = ImageDraw.Draw(picture)
    draw.text((6, 3), title, fill=(0, 0, 0), font=font)
    for k, (frame, caption) in enumerate(zip(frames, captions)):
        x, y = (k % columns) * width, top + (k // columns) * cell
        for n, text in enumerate(caption.split("\n")):
            draw.text((x + 6, y + n * line), text, fill=(0, 0, 0), font=small)
        picture.paste(Image.fromarray(frame), (x, y + 2 * line))
    return np.asarray(picture)


def filmstrip(results: Path, run_id: str, out: Path) -> Path:
    """`filmstrip_<run>.png`: the run at its key moments, one fixed camera, captions with times."""
    from PIL import Image

    replay = load_replay(results, run_id)
    moments = key_moments(replay.row, float(replay.time[-1]))
    camera = _strip_camera(replay.scenario, framing([replay]))
    frames = [camera.frame(_at(replay, t)) for t, _ in moments]
    captions = [f"{t:.2f} s\n{caption}" for t, caption in moments]
    image = _strip_image(frames, captions, f"{replay.label} ({replay.run_id})")
    path = out / f"filmstrip_{replay.run_id}.png"
    Image.fromarray(image).save(path, optimize=False, compress_level=1)  # ~4x faster than the default 6
    return path


def _caption(image: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    picture = Image.fromarray(image)
    ImageDraw.Draw(picture).text((8, 6), text, fill=(0, 0, 0))
    return np.asarray(picture)


def video(results: Path, run_ids: list[str], out: Path, fps: int = 30, speed: float = 1.0) -> Path:
    """An MP4 or GIF of one run, or of two side by side on the same clock and camera (e.g. `none`
    vs `reshape`); `speed` < 1 is slow motion. MP4 through imageio's ffmpeg, GIF through Pillow."""
    import imageio.v2 as imageio

    replays = [load_replay(results, r) for r in run_ids]
    view = framing(replays)
    cameras = [Camera(r.scenario, view, VIDEO_SIZE) for r in replays]
    end = max(float(r.time[-1]) for r in replays)
    times = np.arange(0.0, end + 1e-9, speed / fps)
    frames = []
    try:
        for t in times:
            views = [
                _caption(c.frame(_at(r, t)), f"{arm_name(r.row.pre_impact, r.row.policy)}   t = {t:.2f} s")
                for c, r in zip(cameras, replays)
            ]
            frames.append(np.concatenate(views, axis=1))
    finally:
        for camera in cameras:
            camera.close()
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".gif":
        imageio.mimwrite(out, frames, duration=1000 / fps, loop=0)
    else:
        imageio.mimwrite(out, frames, fps=fps, macro_block_size=8)
    return out
