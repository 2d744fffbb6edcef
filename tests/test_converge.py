"""`fallbench converge`: the step ladder, the change of the last halving, the command's exit codes."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.results.converge import Ladder, convergence_table, ladder, relative_change
from fallbench.results.runner import RunSpec
from fallbench.scenario import Scenario, ScenarioError, ScenarioPoint


def _point(**fields) -> ScenarioPoint:
    return ScenarioPoint(Scenario(name="drop", duration=0.5, **fields), {}, "drop.yaml")


def test_ladder_halves_the_step_and_names_it() -> None:
    item = ladder(_point(physics_dt=0.001), 3)
    assert [p.scenario.physics_dt for p in item.levels] == [0.001, 0.0005, 0.00025]
    assert item.names == ["1 ms", "0.5 ms", "0.25 ms"]
    assert [p.label for p in item.levels] == [
        "drop[physics_dt=0.001]#s0",
        "drop[physics_dt=0.0005]#s0",
        "drop[physics_dt=0.00025]#s0",
    ]
    assert all(p.scenario.control_dt == 0.005 for p in item.levels)


def test_ladder_refuses_a_step_the_scenario_forbids() -> None:
    with pytest.raises(ScenarioError, match="physics_dt"):
        ladder(_point(physics_dt=0.001), 6)  # 0.001 / 32 is below the schema's 1e-4 s


def test_relative_change_uses_the_floor_near_zero() -> None:
    assert relative_change(100.0, 104.0, "imu_peak_z_landing") == pytest.approx(0.04)
    assert relative_change(0.001, 0.002, "knee_limit_margin") == pytest.approx(0.05)  # 0.001 / 0.02
    assert relative_change(float("nan"), float("nan"), "fell") == 0.0


def _specs(item: Ladder) -> list[RunSpec]:
    return [RunSpec(rung, "stiff") for rung in item.levels]


def _runs(item: Ladder, values: list[float]) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "run_id": [spec.run_id for spec in _specs(item)],
            "point": [p.label for p in item.levels],
            "pre_impact": "none",
            "policy": "stiff",
            "status": "ok",
            "imu_peak_z_landing": values,
        }
    )


def test_first_order_error_halves_with_the_step() -> None:
    # value = exact + c * dt: each halving halves the change, 10 -> 5 -> 2.5 % of 100.
    item = ladder(_point(physics_dt=0.001), 3)
    table = convergence_table(
        [item], _runs(item, [120.0, 110.0, 105.0]), _specs(item), ("imu_peak_z_landing",)
    )
    row = table.iloc[0]
    assert (row["1 ms"], row["0.5 ms"], row["0.25 ms"]) == (120.0, 110.0, 105.0)
    assert row["last change"] == pytest.approx(5 / 110)
    assert bool(row["converged"])
    table = convergence_table(
        [item], _runs(item, [100.0, 130.0, 160.0]), _specs(item), ("imu_peak_z_landing",)
    )
    assert not bool(table.iloc[0]["converged"])


def test_converge_command_runs_each_step_and_judges_the_freefall(tmp_path: Path) -> None:
    # A 0.3 m drop ending just after touchdown at sqrt(2 h / g) = 0.247 s: the landing peak of a
    # stiff robot over the first 40 ms of contact is a smooth function of the step.
    scenario = tmp_path / "drop.yaml"
    scenario.write_text("name: drop\nduration: 0.3\ninitial: {height: 0.3}\nphysics_dt: 0.001\n")
    args = [
        "converge",
        str(scenario),
        "--levels",
        "2",
        "--policies",
        "stiff",
        "--results",
        str(tmp_path / "r"),
    ]
    result = CliRunner().invoke(app, [*args, "--jobs", "1"])
    assert "imu_peak_z_landing" in result.output and "1 ms" in result.output and "0.5 ms" in result.output
    stored = pd.read_parquet(tmp_path / "r" / "metrics")
    assert sorted(stored["point"]) == ["drop[physics_dt=0.0005]#s0", "drop[physics_dt=0.001]#s0"]
    assert result.exit_code == 0, result.output
    assert "converged: 7 (metric, case) pairs within 5% of the previous step" in result.stdout


@pytest.mark.parametrize(("halved", "code"), [(104.9, 0), (105.1, 1)])
def test_converge_command_exits_1_when_the_last_halving_moves_a_metric(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, halved: float, code: int
) -> None:
    """Runs made by hand: the landing IMU peak is 100 at the file's step and `halved` at half of it
    (a 4.9 % or 5.1 % change); every other headline metric stays put."""
    import fallbench.results.runner as runner

    def runs(specs: list[RunSpec], results: Path, **_: object) -> pd.DataFrame:
        at_half = [spec.point.scenario.physics_dt < 0.001 for spec in specs]
        return pd.DataFrame(
            {
                "run_id": [spec.run_id for spec in specs],
                "status": "ok",
                "imu_peak_z_landing": [halved if half else 100.0 for half in at_half],
                "knee_limit_margin": 0.5,
            }
        )

    monkeypatch.setattr(runner, "run_sweep", runs)
    scenario = tmp_path / "drop.yaml"
    scenario.write_text("name: drop\nduration: 0.3\ninitial: {height: 0.3}\nphysics_dt: 0.001\n")
    result = CliRunner().invoke(
        app, ["converge", str(scenario), "--levels", "2", "--policies", "stiff", "--results", str(tmp_path)]
    )
    assert result.exit_code == code, result.output
    rows = {line.split()[3]: line.split()[-1] for line in result.stdout.splitlines()[1:3]}
    assert rows == {"imu_peak_z_landing": str(code == 0), "knee_limit_margin": "True"}
    if code:
        assert result.stderr == "1 of 2 (metric, case) pairs moved more than 5% with the last halving\n"
        assert "converged:" not in result.stdout
    else:
        assert result.stdout.endswith("converged: 2 (metric, case) pairs within 5% of the previous step\n")


def test_converge_reuses_a_run_of_the_default_step(tmp_path: Path, sweep) -> None:
    # The rung at the file's own step is the same run as the plain point: found by run id.
    scenario = tmp_path / "drop.yaml"
    scenario.write_text("name: drop\nduration: 0.3\ninitial: {height: 0.3}\n")
    assert sweep(scenario, tmp_path / "r", policies="stiff").exit_code == 0
    result = CliRunner().invoke(
        app,
        ["converge", str(scenario), "--levels", "2", "--policies", "stiff", "--results", str(tmp_path / "r")],
    )
    row = result.output.splitlines()[1]
    assert "nan" not in row.split("imu_peak_z_landing")[1], result.output
    assert len(pd.read_parquet(tmp_path / "r" / "metrics")) == 2  # the plain run and the half step


def test_converge_command_names_a_bad_point(tmp_path: Path) -> None:
    scenario = tmp_path / "drop.yaml"
    scenario.write_text("name: drop\nduration: 0.3\ninitial: {height: 0.3}\n")
    result = CliRunner().invoke(app, ["converge", str(scenario), "--point", "initial.height=2"])
    assert result.exit_code == 2 and "selects no point" in result.stderr
