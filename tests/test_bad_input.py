"""Bad scenario input: one line naming file, line and key; exit code 2; no traceback; nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fallbench.cli import app

GOOD = """name: t
duration: 1.0
initial:
  height: 0.2
"""

CASES = {
    "malformed": ("name: t\nduration: [1.0\n", 3, "", "flow sequence started at line 2"),
    "unknown_key": (GOOD + "pussh: {force: 1}\n", 5, "pussh", "unknown key"),
    "wrong_type": ("name: t\nduration: long\n", 2, "duration", "valid number"),
    "negative_duration": ("name: t\nduration: -1\n", 2, "duration", "greater than 0"),
    "negative_force": (GOOD + "push:\n  force: -5\n", 6, "push.force", "greater than or equal to 0"),
    "unknown_robot": ("name: t\nrobot: atlas\nduration: 1\n", 2, "robot", "unknown robot 'atlas'"),
    "unknown_body": (GOOD + "push:\n  force: 5\n  body: tail_link\n", 7, "push.body", "unknown body"),
    "unknown_joint": ("name: t\nduration: 1\ninitial:\n  joints: {elbow: 0.1}\n", 4, "initial.joints.elbow", "unknown joint"),
    "dt_order": ("name: t\nduration: 1\nphysics_dt: 0.01\ncontrol_dt: 0.005\n", 1, "(top level)", "must not exceed control_dt"),
    "bad_sweep_key": (GOOD + "sweep:\n  push.colour: [1, 2]\n", 6, "push.colour", "unknown key"),
    "bad_sweep_value": (GOOD + "sweep:\n  initial.height: [0.5, -1]\n", 6, "initial.height", "greater than or equal to 0"),
    "overlap": (GOOD + "obstacles:\n  - {type: box, pos: [0, 0, 0.8], size: [0.5, 0.5, 0.5]}\n", 6, "obstacles.0", "intersects the robot"),
    "unknown_policy_param": (GOOD + "policy_params:\n  oneshot: {kp_scale: 0.1}\n", 6, "policy_params.oneshot.kp_scale", "unknown parameter"),
    "bad_swept_policy_param": (GOOD + "sweep:\n  policy_params.stiff.gain_scale: [1, 2]\n  policy_params.adaptive_qp.posture_k: [1]\n",
                               7, "policy_params.adaptive_qp.posture_k", "unknown parameter of 'adaptive_qp'"),
    "bad_gain_scale": (GOOD + "sweep:\n  policy_params.stiff.gain_scale: [1, 0]\n", 6, "policy_params.stiff.gain_scale", "must be > 0"),
    "bad_policy_param_value": (GOOD + "policy_params:\n  adaptive_qp:\n    posture_kp: fast\n", 7,
                               "policy_params.adaptive_qp.posture_kp", "expected a finite number (got 'fast')"),
    "bad_direction_mode": (GOOD + "sweep:\n  policy_params.direction.mode: [auto, jump]\n", 6, "policy_params.direction.mode",
                           "expected one of auto, no_action, lift_leg, take_step, take_step_pis, whole_body_is (got 'jump')"),
    "bad_layout_yaw": (GOOD + "sweep:\n  layout_yaw: [0, left]\n", 6, "layout_yaw", "expected degrees (got 'left')"),
    "unknown_pinned_strategy": (GOOD + "pre_impact: [none, flail]\n", 5, "pre_impact.1", "unknown pre-impact strategy 'flail'"),
    "bad_obstacle_type": (GOOD + "obstacles:\n  - {type: sphere, pos: [2, 0, 0], radius: 1}\n", 6, "obstacles.0", "tag"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_scenario_is_one_clear_line(case: str, tmp_path: Path) -> None:
    text, line, key, reason = CASES[case]
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    results = tmp_path / "results"
    result = CliRunner().invoke(app, ["run", "sweep", str(path), "--results", str(results), "--reports", str(tmp_path / "rep")])
    assert result.exit_code == 2, result.output
    message = result.stderr.strip()
    assert "\n" not in message and "Traceback" not in result.output
    assert message.startswith(f"error: {path}:{line}: "), message
    assert key in message and reason in message, message
    assert not results.exists()


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--policies", "stiff,floppy", "--policies: unknown policy 'floppy'; known: stiff, oneshot, zero, adaptive_qp"),
    ("--pre-impact", "none,flail", "--pre-impact: unknown strategy 'flail'; known: none, reshape"),
])
def test_unknown_policy_or_strategy_is_rejected(tmp_path: Path, option: str, value: str, message: str) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD)
    result = CliRunner().invoke(app, ["run", "sweep", str(path), option, value, "--results", str(tmp_path / "r")])
    assert result.exit_code == 2
    assert message in result.stderr
    assert not (tmp_path / "r").exists()


def test_validate_accepts_shipped_scenarios() -> None:
    root = Path(__file__).resolve().parents[1] / "scenarios"
    files = sorted(str(p) for p in root.glob("*.yaml"))
    result = CliRunner().invoke(app, ["scenarios", "validate", *files])
    assert result.exit_code == 0, result.output
    assert result.output.count(": ok,") == len(files) >= 6
