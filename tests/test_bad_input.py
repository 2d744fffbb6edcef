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
    "unknown_joint": (
        "name: t\nduration: 1\ninitial:\n  joints: {elbow: 0.1}\n",
        4,
        "initial.joints.elbow",
        "unknown joint",
    ),
    "contact_too_fast": (
        "name: t\nduration: 1\nphysics_dt: 0.01\ncontrol_dt: 0.01\n",
        3,
        "physics_dt",
        "exceed contact.time_constant",
    ),
    "dt_order": (
        "name: t\nduration: 1\nphysics_dt: 0.01\ncontrol_dt: 0.005\n",
        3,
        "physics_dt",
        "must not exceed control_dt",
    ),
    "rest_hold_below_step": (
        GOOD + "rest:\n  hold: 0.0001\n",
        6,
        "rest.hold",
        "shorter than one physics step",
    ),
    "rest_threshold_zero": (GOOD + "rest:\n  joint_speed: 0\n", 6, "rest.joint_speed", "greater than 0"),
    "bad_sweep_key": (GOOD + "sweep:\n  push.colour: [1, 2]\n", 6, "push.colour", "unknown key"),
    "bad_sweep_value": (
        GOOD + "sweep:\n  initial.height: [0.5, -1]\n",
        6,
        "initial.height",
        "greater than or equal to 0",
    ),
    "overlap": (
        GOOD + "obstacles:\n  - {type: box, pos: [0, 0, 0.8], size: [0.5, 0.5, 0.5]}\n",
        6,
        "obstacles.0",
        "intersects the robot",
    ),
    "unknown_policy_param": (
        GOOD + "policy_params:\n  oneshot: {kp_scale: 0.1}\n",
        6,
        "policy_params.oneshot.kp_scale",
        "unknown parameter",
    ),
    "negative_posture_noise": (
        GOOD + "  joint_noise: -0.1\n",
        5,
        "initial.joint_noise",
        "greater than or equal to 0",
    ),
    "bad_randomized_noise": (
        GOOD + "randomize:\n  initial.joint_noise: [0.1, 0.9]\n",
        6,
        "initial.joint_noise",
        "less than or equal to 0.5",
    ),
    "bad_swept_policy_param": (
        GOOD
        + "sweep:\n  policy_params.stiff.gain_scale: [1, 2]\n  policy_params.adaptive_qp.posture_k: [1]\n",
        7,
        "policy_params.adaptive_qp.posture_k",
        "unknown parameter of 'adaptive_qp'",
    ),
    "bad_gain_scale": (
        GOOD + "sweep:\n  policy_params.stiff.gain_scale: [1, 0]\n",
        6,
        "policy_params.stiff.gain_scale",
        "must be > 0",
    ),
    "bad_policy_param_value": (
        GOOD + "policy_params:\n  adaptive_qp:\n    posture_kp: fast\n",
        7,
        "policy_params.adaptive_qp.posture_kp",
        "expected a finite number (got 'fast')",
    ),
    "bad_direction_mode": (
        GOOD + "sweep:\n  policy_params.direction.mode: [auto, jump]\n",
        6,
        "policy_params.direction.mode",
        "expected one of auto, no_action, lift_leg, take_step, take_step_pis, whole_body_is (got 'jump')",
    ),
    "bad_qp_solver": (
        GOOD + "policy_params:\n  adaptive_qp: {solver: gurobi}\n",
        6,
        "policy_params.adaptive_qp.solver",
        "expected one of proxsuite, daqp (got 'gurobi')",
    ),
    "bad_reshape_solver": (
        GOOD + "sweep:\n  policy_params.reshape.solver: [daqp, osqp]\n",
        6,
        "policy_params.reshape.solver",
        "expected one of proxsuite, daqp (got 'osqp')",
    ),
    "bad_layout_yaw": (
        GOOD + "sweep:\n  layout_yaw: [0, left]\n",
        6,
        "layout_yaw",
        "expected degrees (got 'left')",
    ),
    "infinite_layout_yaw": (  # found by the fuzzing of test_scenario_fuzz.py (cos(inf) raised)
        GOOD + "sweep:\n  layout_yaw: [0, .inf]\n",
        6,
        "layout_yaw",
        "expected degrees (got inf)",
    ),
    "unknown_pinned_strategy": (
        GOOD + "pre_impact: [none, flail]\n",
        5,
        "pre_impact.1",
        "unknown pre-impact strategy 'flail'",
    ),
    "bad_obstacle_type": (
        GOOD + "obstacles:\n  - {type: sphere, pos: [2, 0, 0], radius: 1}\n",
        6,
        "obstacles.0",
        "tag",
    ),
    # numbers: finite and within the documented ranges
    "infinite_force": (GOOD + "push:\n  force: .inf\n", 6, "push.force", "finite number"),
    "nan_height": ("name: t\nduration: 1\ninitial:\n  height: .nan\n", 4, "initial.height", "finite number"),
    "huge_duration": ("name: t\nduration: 1.0e+12\n", 2, "duration", "less than or equal to 60"),
    "huge_force": (GOOD + "push: {force: 1.0e+9}\n", 5, "push.force", "less than or equal to 10000"),
    "huge_obstacle": (
        GOOD + "obstacles:\n  - {type: box, pos: [5, 0, 0], size: [1, 1, 1000]}\n",
        6,
        "obstacles.0.size.2",
        "less than or equal to 10",
    ),
    "far_obstacle": (
        GOOD + "obstacles:\n  - {type: cylinder, pos: [1.0e+6, 0, 0], radius: 1, height: 1}\n",
        6,
        "obstacles.0.pos.0",
        "less than or equal to 20",
    ),
    "friction": (GOOD + "friction: 50\n", 5, "friction", "less than or equal to 5"),
    "tiny_dt": (
        "name: t\nduration: 1\nphysics_dt: 1.0e-9\n",
        3,
        "physics_dt",
        "greater than or equal to 0.0001",
    ),
    "huge_seed": (GOOD + "seed: 99999999999999\n", 5, "seed", "less than or equal to 4294967295"),
    "step_budget": (
        "name: t\nduration: 50\nphysics_dt: 0.0001\ncontrol_dt: 0.001\n",
        2,
        "duration",
        "over the budget of 200,000 per run",
    ),
    "swept_step_budget": (
        "name: t\nduration: 1\nphysics_dt: 0.0001\ncontrol_dt: 0.001\nsweep:\n  duration: [1, 30]\n",
        6,
        "duration",
        "300,000 physics steps",
    ),
    "nan_policy_param": (
        GOOD + "policy_params:\n  oneshot: {kp_factor: .nan}\n",
        6,
        "policy_params.oneshot.kp_factor",
        "must be a finite number",
    ),
    "too_many_points": (
        GOOD + "seeds: 100\nsweep:\n  push.force: [" + ", ".join(map(str, range(101))) + "]\n",
        6,
        "sweep",
        "10,100 points",
    ),
    "randomize_inf": (
        GOOD + "push: {force: 5}\nrandomize:\n  push.force: [0, .inf]\n",
        7,
        "randomize.push.force.1",
        "finite number",
    ),
    # YAML that scenario data never needs
    "duplicate_key": ("name: t\nduration: 1\nduration: 2\n", 3, "", "duplicate key"),
    "yaml_tag": ("name: t\nduration: !!python/object/apply:os.system [ls]\n", 2, "duration", "YAML tags"),
    "local_tag": ("name: t\nduration: 1\ninitial: !posture {height: 1}\n", 3, "initial", "YAML tags"),
    "alias": (
        "name: t\nduration: 1\ninitial: &i {height: 0.5}\nsweep: {initial: [*i]}\n",
        3,
        "sweep.initial.0",
        "aliases",
    ),  # the line of the anchor
    "billion_laughs": (
        "name: t\nduration: 1\nx: &a [1, 1]\ny: &b [*a, *a]\nz: [*b, *b]\n",
        3,
        "y.0",
        "aliases",
    ),
    "binary_tag": (
        "name: t\nduration: 1\npolicy_params: {oneshot: {kp_factor: !!binary aGVsbG8=}}\n",
        3,
        "policy_params.oneshot.kp_factor",
        "special types (here a bytes)",
    ),
    "deep_nesting": (
        "name: t\nduration: 1\npolicy_params: " + "[" * 40 + "]" * 40 + "\n",
        3,
        "policy_params" + ".0" * 15,
        "nested deeper than 16",
    ),
    "very_deep_nesting": (
        "name: t\nduration: 1\npolicy_params: " + "[" * 5000 + "]" * 5000 + "\n",
        None,
        "",
        "nested far deeper than 16",
    ),
    "list_at_top": ("- name: t\n  duration: 1\n", 1, "", "must be a YAML mapping"),
    "scalar_at_top": ("just some text\n", 1, "", "must be a YAML mapping"),
    "empty": ("", 1, "", "empty file"),
    "only_comments": ("# nothing here\n\n", 1, "", "empty file"),
    "complex_key": ("name: t\nduration: 1\n? [a, b]\n: 1\n", 3, "", "a key must be a plain name"),
}
BYTES = {  # files that are not UTF-8 text
    "binary": (bytes(range(256)) * 4, 1, "binary file"),
    "non_utf8": (b"name: t\nduration: 1\n# caf\xe9\n", 3, "not UTF-8 text (byte 0xe9)"),
    "control_character": (b"name: t\x07\nduration: 1\n", None, "special characters are not allowed"),
    "huge": (b"name: t\nduration: 1\n" + b"#" * (128 << 10) + b"\n", None, "file too large"),
}


def _rejected(sweep, tmp_path: Path, path: Path) -> str:
    results = tmp_path / "results"  # the sweep's summary would go to results/rep
    result = sweep(path, results)
    assert result.exit_code == 2, result.output
    assert result.stdout == "" and "Traceback" not in result.output
    assert result.stderr.count("\n") == 1, result.stderr
    assert not results.exists() and result.simulated == ()
    return result.stderr.strip()


@pytest.mark.parametrize(
    "case",
    [  # rejecting 5,000 nested brackets takes ~10 s
        pytest.param(case, marks=pytest.mark.slow) if case == "very_deep_nesting" else case
        for case in sorted(CASES)
    ],
)
def test_bad_scenario_is_one_clear_line(case: str, tmp_path: Path, sweep) -> None:
    text, line, key, reason = CASES[case]
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    message = _rejected(sweep, tmp_path, path)
    assert message.startswith(f"error: {path}{f':{line}' if line else ''}: {key + ': ' if key else ''}"), (
        message
    )
    assert reason in message, message


@pytest.mark.parametrize("case", sorted(BYTES))
def test_file_that_is_not_text_is_one_clear_line(case: str, tmp_path: Path, sweep) -> None:
    data, line, reason = BYTES[case]
    path = tmp_path / "bad.yaml"
    path.write_bytes(data)
    message = _rejected(sweep, tmp_path, path)
    assert message.startswith(f"error: {path}:{line}: " if line else f"error: {path}: "), message
    assert reason in message, message


@pytest.mark.parametrize(
    ("choice", "value", "message"),
    [
        (
            "policies",
            "stiff,floppy",
            "--policies: unknown policy 'floppy'; known: stiff, oneshot, zero, adaptive_qp, adaptive_qp_hold",
        ),
        (
            "pre_impact",
            "none,flail",
            "--pre-impact: unknown strategy 'flail'; known: none, reshape, direction, onnx",
        ),
    ],
)
def test_unknown_policy_or_strategy_is_rejected(
    tmp_path: Path, sweep, choice: str, value: str, message: str
) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD)
    result = sweep(path, tmp_path / "r", **{choice: value})
    assert result.exit_code == 2
    assert result.stderr == f"error: {message}\n"  # the whole line: every known name, nothing else
    assert not (tmp_path / "r").exists()


def test_unknown_backend_is_rejected(tmp_path: Path, sweep) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD)
    result = sweep(path, tmp_path / "r", "--backend", "bogus")
    assert result.exit_code == 2
    assert result.stderr == "error: --backend: unknown backend 'bogus'; known: auto, fork, loky, dask\n"
    assert not (tmp_path / "r").exists() and result.simulated == ()


def test_validate_accepts_shipped_scenarios() -> None:
    root = Path(__file__).resolve().parents[1] / "scenarios"
    files = sorted(str(p) for p in root.glob("*.yaml"))
    result = CliRunner().invoke(app, ["scenarios", "validate", *files])
    assert result.exit_code == 0, result.output
    assert result.output.count(": ok,") == len(files) >= 6


def test_validate_states_the_default_robot(tmp_path: Path) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text(GOOD)
    result = CliRunner().invoke(app, ["scenarios", "validate", str(path)])
    assert (
        result.exit_code == 0
        and result.output == f"{path}: ok, 1 points, robot talos (default: no `robot` key)\n"
    )
    path.write_text(GOOD + "robot: talos\n")
    assert (
        CliRunner().invoke(app, ["scenarios", "validate", str(path)]).output
        == f"{path}: ok, 1 points, robot talos\n"
    )
