"""Rendering: the replay stored with a run, `fallbench render` without a GL context (one line,
exit 2, nothing written), and a filmstrip and a video where EGL works."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.analysis.metrics import REPLAY_RATE
from fallbench.cli import app
from fallbench.results import store

DROP = "name: drop\nduration: 0.3\ninitial: {height: 0.1}\n"


@pytest.fixture(scope="module")
def stored(tmp_path_factory) -> tuple[Path, str]:
    folder = tmp_path_factory.mktemp("render")
    (folder / "drop.yaml").write_text(DROP)
    result = CliRunner().invoke(
        app,
        ["run", "one", str(folder / "drop.yaml"), "--policy", "zero", "--results", str(folder / "results")],
    )
    assert result.exit_code == 0, result.output
    run_id = next((folder / "results" / "runs").iterdir()).name
    return folder / "results", run_id


def test_time_series_keeps_the_full_qpos_at_the_replay_rate(stored: tuple[Path, str]) -> None:
    results, run_id = stored
    series = store.load_timeseries(results, run_id)
    replay = series[["t"] + [c for c in series.columns if c.startswith("qpos:")]].dropna()
    assert replay.shape[1] - 1 == 39  # TALOS: free joint (7) + 32 joints
    assert np.allclose(np.diff(replay.t), 1 / REPLAY_RATE, atol=1e-6)
    assert np.allclose(replay["qpos:2"], series.loc[replay.index, "base_z"])  # the base height column agrees


@pytest.mark.slow
def test_render_without_gl_is_one_line_and_exit_2(stored: tuple[Path, str], tmp_path: Path) -> None:
    results, run_id = stored
    out = tmp_path / "fall.mp4"
    env = os.environ | {"MUJOCO_GL": "disabled"}  # no OpenGL backend at all
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "fallbench.cli",
            "render",
            run_id[:6],
            "--results",
            str(results),
            "--out",
            str(out),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    message = done.stderr.strip()
    assert "\n" not in message and message.startswith(
        "error: no OpenGL context for offscreen rendering (MUJOCO_GL=disabled"
    )
    assert not out.exists()


def test_render_rejects_unknown_runs_and_formats(stored: tuple[Path, str], tmp_path: Path) -> None:
    results, _ = stored
    unknown = CliRunner().invoke(
        app, ["render", "ffff", "--results", str(results), "--out", str(tmp_path / "x.mp4")]
    )
    assert unknown.exit_code == 2 and "no stored run with id 'ffff'" in unknown.stderr
    bad = CliRunner().invoke(
        app, ["render", "ffff", "--results", str(results), "--out", str(tmp_path / "x.avi")]
    )
    assert bad.exit_code == 2 and "expected a .mp4 or .gif" in bad.stderr


@pytest.mark.slow
def test_filmstrip_and_video_where_gl_works(stored: tuple[Path, str], tmp_path: Path) -> None:
    from fallbench.report.render import RenderUnavailable, filmstrip, key_moments

    results, run_id = stored
    try:
        strip = filmstrip(results, run_id, tmp_path)
    except RenderUnavailable as exc:
        pytest.skip(str(exc))
    assert strip.name == f"filmstrip_{run_id}.png" and strip.stat().st_size > 20_000
    row = store.load_run_row(results, run_id)
    captions = [c for _, c in key_moments(row, 0.299)]
    assert (
        captions[0] == "fall detected"
        and captions[-1] == "end"
        and any("first impact" in c for c in captions)
    )
    result = CliRunner().invoke(
        app,
        [
            "render",
            run_id,
            "--vs",
            run_id,
            "--results",
            str(results),
            "--out",
            str(tmp_path / "fall.gif"),
            "--fps",
            "10",
        ],
    )
    assert result.exit_code == 0, result.output
    import imageio.v2 as imageio

    frames = imageio.mimread(tmp_path / "fall.gif")
    assert (
        len(frames) == 3 and frames[0].shape[1] == 2 * frames[0].shape[0] * 4 // 3
    )  # two 4:3 views side by side


def test_filmstrip_camera_turns_away_from_an_obstacle_that_hides_the_robot() -> None:
    """A robot standing still is seen from its front-left (azimuth 210); a wall there would hide
    it, so the camera takes the first view around it that sees the whole robot."""
    from fallbench.report.render import Replay, _camera_position, _hidden, framing
    from fallbench.scenario import Scenario
    from fallbench.sim.world import build_world

    wall = {"type": "box", "pos": [1.0, 0.6, 1.0], "size": [0.1, 1.6, 2.0], "yaw": 60}
    scenario = Scenario(name="walled", duration=1.0, obstacles=[wall])
    qpos = np.tile(build_world(scenario).model.qpos0, (20, 1))
    replay = Replay("r", scenario, "none + stiff", np.linspace(0.0, 1.0, 20), qpos, pd.Series(dtype=object))
    view = framing([replay])
    centre = np.array(view.lookat)
    assert _hidden(replay, _camera_position(centre, view.distance, 210.0)) > 0
    assert (
        view.azimuth != 210.0 and _hidden(replay, _camera_position(centre, view.distance, view.azimuth)) == 0
    )
