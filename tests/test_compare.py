"""`fallbench compare`: verdicts on a hand-made pair of stores whose changes are known, identical
stores, two selections of one store, and the command's exit codes and messages."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.report.compare import compare
from fallbench.results import store

SEEDS = 10


def _rows(version: str, changed: bool) -> list[dict[str, object]]:
    """Runs of one family, 10 seeds x (stiff, zero). B (`changed`) differs from A by: stiff's landing
    IMU peak -20 +- 2 m/s^2 (better), zero's head force +100 +- 10 N (worse), stiff's knee margin
    +0.05 rad (better: higher), takeover delay +-1 ms about 0 (no clear change), `fell` unchanged."""
    noise = np.random.default_rng(1)
    rows = []
    for seed in range(SEEDS):
        for policy in ("stiff", "zero"):
            jitter = noise.uniform(-1, 1)
            row: dict[str, object] = {
                "run_id": f"{version}{policy}{seed:02d}",
                "robot": "talos",
                "scenario": "my_drop",
                "point": f"my_drop#s{seed}",
                "seed": seed,
                "pre_impact": "none",
                "policy": policy,
                "status": "ok",
                "version:code": version,
                "imu_peak_z_landing": 300.0 + 10 * seed,
                "contact_force_peak_head": 1000.0 + 50 * seed,
                "contact_force_peak_torso": 2000.0 + seed,
                "knee_limit_margin": 0.3 + 0.01 * seed,
                "joint_limit_hits": seed % 3,
                "fell": seed % 2 == 0,
                "takeover_delay": 0.005 + 0.001 * seed,
            }
            if changed:
                if policy == "stiff":
                    row["imu_peak_z_landing"] = float(row["imu_peak_z_landing"]) - 20 + 2 * jitter
                    row["knee_limit_margin"] = float(row["knee_limit_margin"]) + 0.05
                else:
                    row["contact_force_peak_head"] = float(row["contact_force_peak_head"]) + 100 + 10 * jitter
                row["takeover_delay"] = float(row["takeover_delay"]) + (0.001 if seed % 2 else -0.001)
            rows.append(row)
    return rows


def _store(results: Path, *row_sets: list[dict[str, object]]) -> Path:
    for rows in row_sets:
        for row in rows:
            store.write_run(results, str(row["run_id"]), {"run": row["run_id"]}, row, None)
    store.consolidate(results)
    return results


@pytest.fixture(scope="module")
def stores(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("compare")
    return {
        "a": _store(folder / "a", _rows("a", changed=False)),
        "a_again": _store(folder / "a_again", _rows("a", changed=False)),
        "b": _store(folder / "b", _rows("b", changed=True)),
        "both": _store(folder / "both", _rows("a", changed=False), _rows("b", changed=True)),
    }


def _verdicts(a: Path, b: Path) -> dict[tuple[str, str], str]:
    table = compare(store.load_metrics(a), store.load_metrics(b)).table
    return {(row.policy, row.measure): row.verdict for row in table.itertuples()}


def test_verdicts_follow_the_known_changes(stores: dict[str, Path]) -> None:
    verdicts = _verdicts(stores["a"], stores["b"])
    assert verdicts[("stiff", "imu_peak_z_landing")] == "better"
    assert verdicts[("stiff", "knee_limit_margin")] == "better"  # higher is better
    assert verdicts[("zero", "contact_force_peak_head")] == "worse"
    assert verdicts[("zero", "imu_peak_z_landing")] == "no change"
    assert verdicts[("stiff", "takeover_delay")] == "no clear change"
    assert verdicts[("stiff", "fell")] == "no change"
    # and reversed, B -> A: the same changes the other way
    back = _verdicts(stores["b"], stores["a"])
    assert (
        back[("stiff", "imu_peak_z_landing")] == "worse"
        and back[("zero", "contact_force_peak_head")] == "better"
    )
    table = compare(store.load_metrics(stores["a"]), store.load_metrics(stores["b"])).table
    imu = table[(table.policy == "stiff") & (table.measure == "imu_peak_z_landing")].iloc[0]
    assert imu.pairs == SEEDS and -22 < imu.low < imu.change < imu.high < -18


def test_identical_stores_show_no_change(stores: dict[str, Path]) -> None:
    assert set(_verdicts(stores["a"], stores["a_again"]).values()) == {"no change"}


def _compare(*arguments: str):
    return CliRunner().invoke(app, ["compare", *arguments])


def test_command_prints_the_table_and_fails_on_worse_only_when_asked(
    stores: dict[str, Path], tmp_path: Path
) -> None:
    plain = _compare(str(stores["a"]), str(stores["b"]), "--out", str(tmp_path / "out"))
    assert plain.exit_code == 0, plain.output
    assert "20 paired runs (0 ok runs only in A, 0 only in B)" in plain.stdout
    assert "better" in plain.stdout and "worse" in plain.stdout
    for name in ("compare.md", "compare.csv", "compare.png"):
        assert (tmp_path / "out" / name).stat().st_size > 100
    strict = _compare(str(stores["a"]), str(stores["b"]), "--fail-on", "worse")
    assert strict.exit_code == 1 and "1 changes are worse (--fail-on worse)" in strict.stderr
    same = _compare(str(stores["a"]), str(stores["a_again"]), "--fail-on", "worse")
    assert same.exit_code == 0 and "0 better, 0 worse, 0 no clear change, 14 no change" in same.stdout


def test_two_selections_of_one_store(stores: dict[str, Path]) -> None:
    both = str(stores["both"])
    result = _compare(both, "--where-a", "`version:code` == 'a'", "--where-b", "`version:code` == 'b'")
    assert result.exit_code == 0, result.output
    assert "20 paired runs" in result.stdout and "1 worse" in result.stdout
    unselected = _compare(both)
    assert unselected.exit_code == 2
    assert (
        unselected.stderr.strip()
        == "error: compare needs two stores (A B), or one store with --where-a and --where-b"
    )
    twice = _compare(both, both)  # each key twice in one store: no one-to-one pairing
    assert twice.exit_code == 2 and "select one version of them" in twice.stderr


def test_bad_input_is_one_line_and_exit_2(stores: dict[str, Path], tmp_path: Path) -> None:
    a = str(stores["a"])
    cases = {
        ("--fail-on", "better"): "error: --fail-on: unknown value 'better'; known: none, worse",
        ("--where-b", "seed >"): "error: --where-b 'seed >'",
        ("--where-b", "seed > 100"): "error: A and B share no run that ran ok in both",
        ("--key", "robot,colour"): "error: --key: A has no column colour to pair runs on",
    }
    for options, message in cases.items():
        result = _compare(a, a, *options)
        assert result.exit_code == 2 and result.stderr.startswith(message), (options, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1
    missing = _compare(str(tmp_path / "nowhere"), a)
    assert missing.exit_code == 2 and "no results store here" in missing.stderr


def test_a_and_b_are_read_over_the_pairs_that_have_both(tmp_path: Path) -> None:
    """A landing peak that only some runs of A have (a landing the other side never made) is left
    out of A's and B's values with its pair, so the columns agree with the change beside them."""
    a, b = _rows("a", changed=False), _rows("b", changed=False)
    for row in a[:6]:
        row["imu_peak_z_landing"] = float("nan")
    table = compare(
        store.load_metrics(_store(tmp_path / "a", a)), store.load_metrics(_store(tmp_path / "b", b))
    ).table
    imu = table[(table.policy == "stiff") & (table.measure == "imu_peak_z_landing")].iloc[0]
    assert imu.pairs == 7 and imu.change == 0 and imu.A == imu.B
