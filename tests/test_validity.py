"""The report's numerical validity: runs at half the step are paired with the default step's and kept
out of the rankings."""

from __future__ import annotations

import pandas as pd
import pytest

from fallbench.report.validity import DEFAULT_STEP, robust_claims, split_steps, step_changes


def _runs(step: float, imu: float, fell: bool) -> pd.DataFrame:
    label = f"physics_dt={step:g}"
    return pd.DataFrame(
        {
            "robot": "talos",
            "point": [f"drop[initial.height=1,{label}]#s0", f"drop[{label},initial.height=0.5]#s0"],
            "policy": "stiff",
            "pre_impact": "none",
            "status": "ok",
            "physics_dt": step,
            "imu_peak_z_landing": [imu, 100.0],
            "fell": [fell, False],
        }
    )


def test_split_keeps_the_default_step_for_the_rankings() -> None:
    runs = pd.concat([_runs(DEFAULT_STEP, 200.0, False), _runs(DEFAULT_STEP / 2, 210.0, True)])
    default, halved = split_steps(runs)
    assert (default.physics_dt == DEFAULT_STEP).all() and (halved.physics_dt == DEFAULT_STEP / 2).all()
    assert split_steps(runs.drop(columns="physics_dt"))[1].empty  # older stores: all at the default


def test_step_changes_pair_the_same_fall() -> None:
    default, halved = _runs(DEFAULT_STEP, 200.0, False), _runs(DEFAULT_STEP / 2, 210.0, True)
    table = step_changes(default, halved).set_index("metric")
    assert table.loc["imu_peak_z_landing", "runs"] == 2
    assert table.loc["imu_peak_z_landing", "median change (%)"] == pytest.approx(2.5)  # 5 % and 0 %
    assert table.loc["imu_peak_z_landing", "worst change (%)"] == pytest.approx(5.0)
    assert table.loc["fell", "worst change (%)"] == 100.0  # one fall more, judged on the floor of 1


def test_claims_without_half_step_runs_are_unchanged() -> None:
    claims = pd.DataFrame({"robot": ["talos"], "scope": ["1 m drop"], "claim": ["x"], "verdict": ["holds"]})
    assert robust_claims(claims, pd.DataFrame()).equals(claims)


def test_the_report_counts_half_step_runs_apart() -> None:
    from fallbench.report import _counted

    default, halved = _runs(DEFAULT_STEP, 200.0, False), _runs(DEFAULT_STEP / 2, 210.0, True)
    assert (
        _counted(default, halved) == "2 runs (and 2 at another physics step, in the numerical validity only)"
    )
    assert _counted(default, halved.iloc[0:0]) == "2 runs"
