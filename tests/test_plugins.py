"""Strategies and gain policies from another package, found through entry points: the example
plug-in under examples/ runs end to end through `fallbench run one`."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

EXAMPLE = ROOT / "examples" / "fallbench-plugin-example"
SCENARIO = """name: plugin_push
robot: talos
duration: 1.2
push: {force: 618, duration: 0.1, start: 0.1, direction: 0}
"""


def _installed(site: Path) -> dict[str, str]:
    """An environment where the example is an installed distribution: its source on the path and a
    dist-info folder holding the entry points of its pyproject.toml (what pip install writes)."""
    info = site / "fallbench_crouch-0.1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fallbench-crouch\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(
        "[fallbench.strategies]\ncrouch = fallbench_crouch:CrouchStrategy\n\n"
        "[fallbench.policies]\nsoft = fallbench_crouch:SoftPolicy\n"
    )
    return os.environ | {"PYTHONPATH": os.pathsep.join([str(site), str(EXAMPLE / "src")])}


def test_entry_points_match_the_example_pyproject() -> None:
    text = (EXAMPLE / "pyproject.toml").read_text()
    assert (
        'crouch = "fallbench_crouch:CrouchStrategy"' in text
        and 'soft = "fallbench_crouch:SoftPolicy"' in text
    )


@pytest.mark.slow
def test_plugin_strategy_and_policy_run_through_the_cli(tmp_path: Path) -> None:
    env = _installed(tmp_path / "site")
    scenario = tmp_path / "push.yaml"
    scenario.write_text(SCENARIO)
    cli = [
        sys.executable,
        "-m",
        "fallbench.cli",
        "run",
        "one",
        str(scenario),
        "--results",
        str(tmp_path / "results"),
    ]
    done = subprocess.run(
        cli + ["--pre-impact", "crouch", "--policy", "soft"],
        env=env,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr
    rows = dict(line.split(None, 1) for line in done.stdout.splitlines() if len(line.split(None, 1)) == 2)
    assert rows["pre_impact"] == "crouch" and rows["policy"] == "soft" and rows["status"] == "ok"
    assert float(rows["crouch_knee_change_rad"]) > 0.05  # the strategy ran and bent the knees
    unknown = subprocess.run(
        cli + ["--pre-impact", "crouch"], capture_output=True, text=True, cwd=ROOT
    )  # not installed here
    assert unknown.returncode == 2 and "unknown strategy 'crouch'" in unknown.stderr
