"""`fallbench check`: passes on an unchanged run, fails on a perturbed metric, a NaN, a missing run, a new failure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results.regress import (
    Tolerance,
    Tolerances,
    changed_versions,
    compare,
    load_tolerances,
    read_baseline,
    write_baseline,
)

SUITE = """name: tiny
duration: 0.7
initial: {height: 0.3}
"""
TOLERANCES = Path(__file__).resolve().parents[1] / "baselines" / "tolerances.yaml"


@pytest.fixture
def checked(tmp_path: Path):
    suite = tmp_path / "suite.yaml"
    suite.write_text(SUITE)
    baseline = tmp_path / "baseline.csv"

    def check(*extra: str):
        return CliRunner().invoke(
            app,
            [
                "check",
                "--suite",
                str(suite),
                "--baseline",
                str(baseline),
                "--tolerances",
                str(TOLERANCES),
                "--policies",
                "stiff,zero",
                "--results",
                str(tmp_path / "r"),
                "--jobs",
                "1",
                *extra,
            ],
        )

    result = check("--update")
    assert result.exit_code == 0 and "baseline updated" in result.output
    return check, baseline


def _edit_suite(baseline: Path, text: str) -> None:
    (baseline.parent / "suite.yaml").write_text(text)


def test_unchanged_run_passes(checked) -> None:
    check, _ = checked
    result = check()
    assert result.exit_code == 0, result.output
    assert result.output.startswith("check ok: 2 cases")


def test_perturbed_metric_fails_with_a_table(checked) -> None:
    check, baseline = checked
    frame = read_baseline(baseline)
    frame.loc[frame.policy == "zero", "imu_peak_z"] *= 1.5
    write_baseline(frame, baseline)
    result = check()
    assert result.exit_code == 1
    assert "imu_peak_z" in result.output and "zero" in result.output and "tolerance" in result.output


def test_nan_now_fails(checked) -> None:
    check, baseline = checked
    _edit_suite(baseline, SUITE.replace("duration: 0.7", "duration: 0.05"))  # ends before the impact
    result = check()
    assert result.exit_code == 1
    assert "impact_time" in result.output and "nan" in result.output


def test_missing_run_fails(checked) -> None:
    check, baseline = checked
    frame = read_baseline(baseline)
    extra = frame.iloc[[0]].assign(point="gone#s0")
    write_baseline(pd.concat([frame, extra], ignore_index=True), baseline)
    result = check()
    assert result.exit_code == 1 and "gone#s0" in result.output and "missing" in result.output


def test_new_failure_fails(checked) -> None:
    check, baseline = checked
    _edit_suite(
        baseline,
        SUITE
        + "physics_dt: 0.01\ncontrol_dt: 0.01\ncontact: {time_constant: 0.02, stop_time_constant: 0.02}\n"
        "push: {force: 10000, duration: 0.1, start: 0.0, body: gripper_left_fingertip_1_link}\n",
    )
    result = check()
    assert result.exit_code == 1 and "status" in result.output and "diverged" in result.output


def test_corrupt_baseline_is_an_error_naming_case_and_metric(checked) -> None:
    check, baseline = checked
    good = baseline.read_text()
    header, *rows = good.splitlines()
    columns = header.split(",")
    zero = next(i for i, row in enumerate(rows) if ",zero," in row)
    for bad, reason in (
        ("nan", "'nan' is not a finite number"),
        ("inf", "'inf' is not a finite number"),
        ("-Infinity", "'-Infinity' is not a finite number"),
        ("high", "'high' is not a finite number"),
    ):
        cells = rows[zero].split(",")
        cells[columns.index("imu_peak_z")] = bad
        baseline.write_text("\n".join([header, *rows[:zero], ",".join(cells), *rows[zero + 1 :]]) + "\n")
        result = check()
        assert result.exit_code == 2, (bad, result.output)
        assert (
            result.stderr == f"error: {baseline}:{zero + 2}: tiny#s0 / zero / none: imu_peak_z: {reason} "
            "(leave the cell empty if the metric does not apply to this case)\n"
        )
    dropped = columns.index("knee_limit_margin")
    baseline.write_text(
        "\n".join(
            ",".join(c for i, c in enumerate(line.split(",")) if i != dropped) for line in good.splitlines()
        )
        + "\n"
    )
    result = check()
    assert result.exit_code == 2 and result.stderr.startswith(
        f"error: {baseline}:1: missing column(s) knee_limit_margin"
    )


def test_metric_that_did_not_apply_must_stay_absent(checked) -> None:
    check, baseline = checked
    frame = read_baseline(baseline)
    frame.loc[frame.policy == "stiff", "impact_time"] = float(
        "nan"
    )  # written as an empty cell: "does not apply"
    write_baseline(frame, baseline)
    result = check()
    assert result.exit_code == 1 and "impact_time" in result.output and "n/a" in result.output


def test_software_versions_that_changed_are_named_before_comparing(checked) -> None:
    check, baseline = checked
    frame = read_baseline(baseline)
    frame["version:mujoco"] = "0.0.1"
    write_baseline(frame, baseline)
    result = check()
    assert result.exit_code == 0, result.output
    assert "software changed since" in result.stderr and "mujoco 0.0.1 -> " in result.stderr


def test_tolerances_of_another_version_are_refused(tmp_path: Path) -> None:
    old = tmp_path / "tolerances.yaml"
    old.write_text("version: 1\nmetrics: {imu_peak_z: {abs: 1}}\n")
    with pytest.raises(ValueError, match="expected `version: 2`"):
        load_tolerances(old)


def _seeded_cases(values: dict[str, np.ndarray], landing: np.ndarray) -> pd.DataFrame:
    """One group of seeds of one policy, with a per-run and a distribution metric."""
    return pd.DataFrame(
        {
            "point": [f"drop#s{seed}" for seed in range(len(landing))],
            "group": "drop",
            "policy": "stiff",
            "pre_impact": "none",
            "status": "ok",
            "error": "",
            "impact_speed": landing,
            **values,
        }
    )


TWO_KINDS = Tolerances(
    per_run={"impact_speed": Tolerance(0.02, 0.0)},
    distribution={"torque_demand_ratio_max": Tolerance(0.05, 0.05)},
)


def test_chaotic_whole_episode_metric_passes_when_its_spread_is_unchanged() -> None:
    rng = np.random.default_rng(1)
    landing = rng.uniform(3.0, 5.0, 16)
    chaotic = rng.lognormal(2.0, 1.0, 16)  # a heavy-tailed whole-episode measure
    baseline = _seeded_cases({"torque_demand_ratio_max": chaotic}, landing)
    # A rounding change: every case moves a lot, the spread over seeds does not.
    now = _seeded_cases({"torque_demand_ratio_max": rng.permutation(chaotic)}, landing)
    assert compare(baseline, now, TWO_KINDS) == []
    # Run by run the same change is a regression on most cases: the reason for comparing medians.
    per_case = Tolerances(per_run={"torque_demand_ratio_max": Tolerance(0.05, 0.05)}, distribution={})
    assert len(compare(baseline, now, per_case)) > 8


def test_shifted_whole_episode_distribution_fails() -> None:
    rng = np.random.default_rng(2)
    landing = rng.uniform(3.0, 5.0, 16)
    values = rng.normal(10.0, 1.0, 16)
    baseline = _seeded_cases({"torque_demand_ratio_max": values}, landing)
    found = compare(baseline, _seeded_cases({"torque_demand_ratio_max": values * 2}, landing), TWO_KINDS)
    assert [r.metric for r in found] == ["torque_demand_ratio_max (median)"]
    assert found[0].case == "drop / stiff / none (16 seeds)" and "noise" in found[0].tolerance


def test_landing_metric_is_still_compared_run_by_run() -> None:
    rng = np.random.default_rng(3)
    landing = rng.uniform(3.0, 5.0, 16)
    values = {"torque_demand_ratio_max": rng.normal(10.0, 1.0, 16)}
    moved = landing.copy()
    moved[5] += 0.1  # one case lands 0.1 m/s faster
    found = compare(_seeded_cases(values, landing), _seeded_cases(values, moved), TWO_KINDS)
    assert [(r.case, r.metric) for r in found] == [("drop#s5 / stiff / none", "impact_speed")]


def test_changed_versions_names_each_package() -> None:
    baseline = pd.DataFrame({"version:mujoco": ["3.3.0"], "version:pin": ["4.1.0"]})
    now = pd.DataFrame({"version:mujoco": ["4.0.0"], "version:pin": ["4.1.0"]})
    assert changed_versions(baseline, now) == ["mujoco 3.3.0 -> 4.0.0"]
