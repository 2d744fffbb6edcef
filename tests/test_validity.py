"""The report's numerical validity: runs at half the step are paired with the default step's and kept
out of the rankings."""

from __future__ import annotations

import pandas as pd
import pytest

from fallbench.report.papers.claims import robust_claims
from fallbench.report.validity import DEFAULT_STEP, split_steps, step_changes


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
    from fallbench.report.index_page import counted

    default, halved = _runs(DEFAULT_STEP, 200.0, False), _runs(DEFAULT_STEP / 2, 210.0, True)
    assert (
        counted(default, halved) == "2 runs (and 2 at another physics step, in the numerical validity only)"
    )
    assert counted(default, halved.iloc[0:0]) == "2 runs"


def _drops(imu: dict[str, float], knee: dict[str, float], step: float) -> pd.DataFrame:
    """1 m and 0.5 m drops, one run per policy each: landing IMU peak (m/s^2) and knee margin (rad)."""
    return pd.DataFrame(
        {
            "robot": "talos",
            "scenario": "drop",
            "point": f"drop[initial.height={height:g},physics_dt={step:g}]#s0",
            "param:initial.height": height,
            "physics_dt": step,
            "policy": policy,
            "pre_impact": "none",
            "status": "ok",
            "imu_peak_z_landing": imu[policy],
            "imu_peak_z": imu[policy],
            "knee_limit_margin": knee[policy],
            "torque_demand_ratio_landing": 0.5,
            "torque_demand_ratio_max": 0.5,
            "torque_ratio_max": 0.5,
        }
        for height in (1.0, 0.5)
        for policy in imu
    )


def test_claims_at_half_the_step_say_whether_each_verdict_is_robust() -> None:
    """stiff's IMU peak is the highest at the default step and the lowest at half of it: that claim
    is not robust; the knee claims hold at both steps: robust. A claim the half-step runs cannot
    decide (no zero runs) has no verdict there."""
    from fallbench.report.papers.claims import claims_table

    knee = {"stiff": 0.1, "zero": -0.01}
    default = _drops({"stiff": 300.0, "zero": 100.0}, knee, DEFAULT_STEP)
    claims = claims_table(default)
    halved = _drops({"stiff": 100.0, "zero": 300.0}, knee, DEFAULT_STEP / 2)
    table = robust_claims(claims, halved)
    assert table[list(claims.columns)].equals(claims)  # the claims as they were, two columns added
    by_claim = table.set_index(["scope", "claim"])[["verdict", "verdict at half the step", "robust"]]
    for scope in ("1 m drop", "all drops (2 points)"):
        assert by_claim.loc[scope].to_dict("index") == {
            "stiff has the highest IMU acceleration (landing)": {
                "verdict": "holds",
                "verdict at half the step": "does not hold",
                "robust": "no",
            },
            "stiff stays off the knee stop": {
                "verdict": "holds",
                "verdict at half the step": "holds",
                "robust": "yes",
            },
            "zero reaches the knee's mechanical stop": {
                "verdict": "holds",
                "verdict at half the step": "holds",
                "robust": "yes",
            },
        }
    stiff_only = robust_claims(claims, halved[halved.policy == "stiff"]).set_index(["scope", "claim"])
    assert (
        stiff_only.loc[("1 m drop", "zero reaches the knee's mechanical stop"), "verdict at half the step"]
        == "-"
    )
    assert stiff_only.loc[("1 m drop", "zero reaches the knee's mechanical stop"), "robust"] == "-"
    assert stiff_only.loc[("1 m drop", "stiff stays off the knee stop"), "robust"] == "yes"
