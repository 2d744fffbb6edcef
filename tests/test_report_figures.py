"""The report's pictures chosen by the data (filmstrip picks on scenario names of a user's own), the
forest plot's numbers on hand-computable rows, the figure cache (a changed run is drawn again, an
unchanged one is not) and PNG by default, SVG with `--svg`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fallbench.cli import app
from fallbench.report import drawing
from fallbench.report.filmstrips import damage, family_picks, picks
from fallbench.report.forest import forest_table, paired_changes, pools
from fallbench.report.papers.reshape import TIMELINE_GROUPS, draw_reshaped_falls
from fallbench.results import store
from fallbench.robots import get_robot


def _row(run_id: str, family: str, point: str, seed: int, strategy: str, policy: str, **metrics) -> dict:
    return {
        "run_id": run_id,
        "robot": "talos",
        "scenario": family,
        "point": point,
        "seed": seed,
        "status": "ok",
        "error": "",
        "pre_impact": strategy,
        "policy": policy,
    } | metrics


def test_filmstrips_pick_each_arms_typical_and_worst_fall_under_any_name() -> None:
    """One damage measure (head force): damage is its percentile rank in the family; typical = nearest
    the arm's median damage, worst = the arm's highest."""
    heads = {("none", "stiff"): [100.0, 500.0, 300.0], ("reshape", "zero"): [600.0, 200.0, 400.0]}
    rows = [
        _row(
            f"{s[0]}{p[0]}{seed}",
            "my_own_fall",
            f"my_own_fall#s{seed}",
            seed,
            s,
            p,
            contact_force_peak_head=v,
        )
        for (s, p), values in heads.items()
        for seed, v in enumerate(values)
    ]
    runs = pd.DataFrame(rows)
    scores = damage(runs)
    assert scores.tolist() == [1 / 6, 5 / 6, 3 / 6, 1.0, 2 / 6, 4 / 6]
    chosen = {(p.pre_impact, p.policy, p.role): p for p in picks(runs)}
    assert {k: p.run_id for k, p in chosen.items()} == {
        ("none", "stiff", "typical"): "ns2",  # 300 N: the arm's median
        ("none", "stiff", "worst"): "ns1",  # 500 N
        ("reshape", "zero", "typical"): "rz2",  # 400 N
        ("reshape", "zero", "worst"): "rz0",  # 600 N
    }
    assert chosen[("none", "stiff", "worst")].family == "my_own_fall"
    assert chosen[("none", "stiff", "worst")].damage == pytest.approx(5 / 6)


def test_filmstrips_by_default_show_the_best_the_reference_and_the_worst_fall() -> None:
    """`--filmstrips family` (the default): the typical fall of the best arm and of none + stiff,
    and the family's worst fall over every arm; a third arm's falls are not drawn."""
    heads = {
        ("none", "stiff"): [100.0, 500.0, 300.0],
        ("reshape", "zero"): [600.0, 200.0, 400.0],
        ("direction", "oneshot"): [150.0, 250.0, 350.0],
    }
    runs = pd.DataFrame(
        [
            _row(f"{s[0]}{p[0]}{seed}", "mine", f"mine#s{seed}", seed, s, p, contact_force_peak_head=v)
            for (s, p), values in heads.items()
            for seed, v in enumerate(values)
        ]
    )
    arms = [("direction", "oneshot"), ("none", "stiff"), ("reshape", "zero")]
    chosen = family_picks("talos", "mine", runs, arms, "family")
    assert [(p.pre_impact, p.role, p.run_id) for p in chosen] == [
        ("direction", "typical", "do1"),  # the best arm's median (250 N)
        ("none", "typical", "ns2"),  # the reference's median (300 N)
        ("reshape", "worst", "rz0"),  # 600 N: the family's worst
    ]
    assert len(family_picks("talos", "mine", runs, arms, "all")) == 6
    with pytest.raises(ValueError, match="scope"):
        family_picks("talos", "mine", runs, arms, "some")


def test_damage_orients_every_measure_toward_more_damage() -> None:
    """A lower knee margin and a fall are more damage; the damage is the mean over the measures."""
    runs = pd.DataFrame(
        [
            _row("a", "f", "f#s0", 0, "none", "stiff", knee_limit_margin=0.5, fell=False),
            _row("b", "f", "f#s1", 1, "none", "stiff", knee_limit_margin=-0.1, fell=True),
        ]
    )
    assert damage(runs).tolist() == [0.5, 1.0]  # a: (0.5 + 0.5) / 2 (fell ties), b: (1 + 1) / 2


def _forest_runs() -> pd.DataFrame:
    """Three points x one seed: none+stiff, none+zero (head force reference + 10, 20, 30 N; fell on
    one of three), and a point only `zero` ran (no pair, left out)."""
    rows = []
    for k, (reference, change) in enumerate([(100.0, 10.0), (200.0, 30.0), (300.0, 20.0)]):
        point = f"lab[x={k}]#s0"
        rows.append(
            _row(f"s{k}", "lab", point, 0, "none", "stiff", contact_force_peak_head=reference, fell=False)
        )
        rows.append(
            _row(
                f"z{k}",
                "lab",
                point,
                0,
                "none",
                "zero",
                contact_force_peak_head=reference + change,
                fell=k == 1,
            )
        )
    rows.append(
        _row("z9", "lab", "lab[x=9]#s0", 0, "none", "zero", contact_force_peak_head=5000.0, fell=True)
    )
    return pd.DataFrame(rows[::-1])  # order does not matter: pairs are by point and seed


def test_forest_plot_numbers_are_paired_changes_against_none_stiff() -> None:
    changes = paired_changes(_forest_runs()).set_index(["policy", "measure"])
    assert ("stiff", "contact_force_peak_head") not in changes.index  # the reference is the zero line
    head = changes.loc[("zero", "contact_force_peak_head")]
    assert head.value == 20.0 and head.pairs == 3 and head.reference == 200.0  # median of 10, 30, 20
    assert 10.0 <= head.low <= 20.0 <= head.high <= 30.0 and head.unit == "N"
    fell = changes.loc[("zero", "fell")]
    assert fell.value == pytest.approx(1 / 3) and fell.pairs == 3  # the mean change of the fraction


def test_probability_of_improvement_scores_each_pair_over_the_measures() -> None:
    """none + zero hits the head harder in all 3 pairs (0 each) and falls where none + stiff does
    not in one (0), as often in two (0.5): pair scores 0.25, 0, 0.25."""
    changes = paired_changes(_forest_runs()).set_index(["policy", "measure"])
    improvement = changes.loc[("zero", "improvement")]
    assert improvement.value == pytest.approx(1 / 6) and improvement.pairs == 3
    assert (improvement.low, improvement.high) == (0.0, 0.25)
    assert improvement.unit == "share of pairs"


def test_the_change_table_is_the_forest_and_counts_pairs_whose_reference_is_0() -> None:
    """Head forces of none + stiff 0 in 4 of 6 pairs: every pair counts (a change is a difference),
    the table says how many references are 0, and its numbers are the forest's."""
    rows = []
    for k, (reference, ours) in enumerate([(0, 0), (0, 0), (0, 0), (0, 0), (100, 50), (200, 100)]):
        point = f"lab[x={k}]#s0"
        rows.append(_row(f"s{k}", "lab", point, 0, "none", "stiff", contact_force_peak_head=float(reference)))
        rows.append(_row(f"z{k}", "lab", point, 0, "none", "zero", contact_force_peak_head=float(ours)))
    changes = paired_changes(pd.DataFrame(rows))
    head = changes.set_index("measure").loc["contact_force_peak_head"]
    assert (head.value, head.pairs, head.reference, head.zero_references) == (0.0, 6, 0.0, 4)
    table = forest_table(changes).set_index("arm")
    assert table.loc["none + zero", "pairs"] == 6
    assert table.loc["none + zero", "head peak force (N)"] == f"+0 [{head.low:+.3g}, +0] (ref. 0, 0 in 4/6)"


def test_pooled_forests_pool_only_families_where_the_same_arms_ran() -> None:
    """`reshape` ran in one family only: it gets its own pool, and the other pool's reference is
    its own pairs' (not the first row's)."""
    runs = _forest_runs().assign(scenario="a")
    other = _forest_runs().assign(
        scenario="b", contact_force_peak_head=lambda r: r.contact_force_peak_head * 10
    )
    other = other.assign(run_id=other.run_id + "b")
    reshaped = other[other.policy == "zero"].assign(
        pre_impact="reshape", run_id=lambda r: r.run_id + "r", contact_force_peak_head=1.0
    )
    found = pools(pd.concat([runs, other, reshaped]))
    assert [pool.families for pool in found] == [["b"], ["a"]]
    assert sorted(set(found[0].changes.name)) == ["none + zero", "reshape + zero"]
    head = found[1].changes.set_index("measure").loc["contact_force_peak_head"]
    assert head.reference == 200.0 and head.pairs == 3


def test_forest_interval_is_the_bootstrap_of_the_differences() -> None:
    runs = _forest_runs()
    runs.loc[runs.run_id == "z1", "contact_force_peak_head"] = 210.0  # changes 10, 10, 20
    head = paired_changes(runs).set_index(["policy", "measure"]).loc[("zero", "contact_force_peak_head")]
    assert (head.value, head.low, head.high) == (10.0, 10.0, 20.0)


# ---------------------------------------------------------------- the figure cache

CALLS: list[str] = []


def _count_and_write(out: Path, stem: str, text: str) -> list[Path]:
    CALLS.append(stem)
    path = out / f"{stem}.txt"
    path.write_text(text)
    return [path]


def _store_with_runs(results: Path, ids: list[str]) -> None:
    for rid in ids:
        folder = store.run_dir(results, rid)
        folder.mkdir(parents=True)
        (folder / "timeseries.parquet").write_bytes(rid.encode() * 100)


def test_a_figure_is_drawn_again_only_when_its_runs_or_arguments_change(tmp_path: Path) -> None:
    results, out = tmp_path / "results", tmp_path / "out"
    out.mkdir()
    _store_with_runs(results, ["a", "b"])

    def jobs(text: str = "x") -> list[drawing.Figure]:
        return [
            drawing.Figure("fig_a", _count_and_write, (out, "a", text), ("a",)),
            drawing.Figure("fig_b", _count_and_write, (out, "b", "x"), ("b",)),
        ]

    CALLS.clear()
    first = drawing.draw(jobs(), results, out)
    assert (first.drawn, first.cached, sorted(CALLS)) == (2, 0, ["a", "b"])
    again = drawing.draw(jobs(), results, out)
    assert (again.drawn, again.cached, len(CALLS)) == (0, 2, 2) and again.paths == first.paths

    CALLS.clear()
    (store.run_dir(results, "a") / "timeseries.parquet").write_bytes(b"another fall")
    changed = drawing.draw(jobs(), results, out)
    assert (changed.drawn, CALLS) == (1, ["a"])  # only the figure of the changed run

    CALLS.clear()
    assert drawing.draw(jobs("y"), results, out).drawn == 1 and CALLS == ["a"]  # its arguments changed
    (out / "b.txt").unlink()
    CALLS.clear()
    assert drawing.draw(jobs("y"), results, out).drawn == 1 and CALLS == ["b"]  # its file went missing
    CALLS.clear()
    assert drawing.draw(jobs("y"), results, out, vector=True).drawn == 2  # SVG wanted: drawn again


def test_a_group_of_figures_is_one_task_for_one_worker_and_each_is_cached_by_its_name(
    tmp_path: Path, monkeypatch
) -> None:
    """Figures added together with the same group (a scene's filmstrips) go to the workers as one
    task, at the place of the group's first figure; each keeps its own files and cache entry."""
    from concurrent.futures import Future

    results, out = tmp_path / "results", tmp_path / "out"
    out.mkdir()
    _store_with_runs(results, ["a", "b", "c"])
    tasks: list[list[str]] = []

    class Pool:  # draws each task at once, in this process
        def submit(self, function, figures, vector):
            tasks.append([f.name for f in figures])
            future: Future = Future()
            future.set_result(function(figures, vector))
            return future

    monkeypatch.setattr(drawing, "_executor", lambda jobs: Pool())
    figures = [
        drawing.Figure("fig_a", _count_and_write, (out, "a", "x"), ("a",), group="scene"),
        drawing.Figure("fig_b", _count_and_write, (out, "b", "x"), ("b",)),
        drawing.Figure("fig_c", _count_and_write, (out, "c", "x"), ("c",), group="scene"),
    ]
    first = drawing.draw(figures, results, out, jobs=2)
    assert tasks == [["fig_a", "fig_c"], ["fig_b"]]
    assert first.drawn == 3 and first.paths == {
        n: [out / f"{n[-1]}.txt"] for n in ("fig_a", "fig_b", "fig_c")
    }
    tasks.clear()
    (out / "c.txt").unlink()
    again = drawing.draw(figures, results, out, jobs=2)
    assert tasks == [["fig_c"]] and (again.drawn, again.cached) == (1, 2)


# ---------------------------------------------------------------- the whole report


def _synthetic_store(results: Path) -> None:
    rng = np.random.default_rng(0)
    for k in range(12):
        strategy, policy = [("none", "stiff"), ("none", "zero"), ("reshape", "zero")][k % 3]
        seed = k // 3
        row = _row(
            f"r{k:03d}",
            "a_name_of_mine",
            f"a_name_of_mine#s{seed}",
            seed,
            strategy,
            policy,
            **{"param:x": float(seed)},
            imu_peak_z=100 + 10 * rng.random(),
            contact_force_peak_head=1000 * rng.random(),
            contact_force_peak_torso=500.0,
            knee_limit_margin=0.3,
            joint_limit_hits=0,
            torque_demand_ratio_max=1.0,
            contact_force_peak=2000.0,
            fell=True,
            vulnerable_hits=int(rng.integers(0, 3)),
            impact_time=0.5,
            first_impact_group="hands",
            first_impact_safe=True,
            obstacle_force_peak=0.0,
            landing_error=np.nan,
            time_to_first_impact=0.5,
            contact_force_peak_bw=2.0,
        )
        store.write_run(results, row["run_id"], {"point": row["point"]}, row, None)
    store.consolidate(results)


def test_png_by_default_svg_on_request_and_forest_plots_on_top(tmp_path: Path) -> None:
    results = tmp_path / "results"
    _synthetic_store(results)
    for options, out in (([], tmp_path / "png"), (["--svg"], tmp_path / "svg")):
        done = CliRunner().invoke(app, ["report", "--results", str(results), "--out", str(out), *options])
        assert done.exit_code == 0, done.output
    assert list((tmp_path / "png").glob("*.png")) and not list((tmp_path / "png").glob("*.svg"))
    assert {p.stem for p in (tmp_path / "svg").glob("*.svg")} == {
        p.stem for p in (tmp_path / "svg").glob("*.png")
    }
    for page in ("index.html", "family_talos_a_name_of_mine.html"):
        text = (tmp_path / "png" / page).read_text()
        forest, table = text.index('src="forest_'), text.index("<table")
        assert forest < table  # the figure first, the tables below
    assert "![talos forest plot](forest_talos.png)" in (tmp_path / "png" / "summary.md").read_text()
    again = CliRunner().invoke(app, ["report", "--results", str(results), "--out", str(tmp_path / "png")])
    assert "0 figures drawn" in again.output


@pytest.mark.slow
def test_report_of_scenarios_with_names_of_their_own(tmp_path: Path, sweep) -> None:
    """A drop under another name: a forest plot, 002's figures at one point, the default filmstrips
    (the best's and none + stiff's typical fall, the worst); with `--filmstrips all --paper-figures
    all` every policy's typical and worst fall and 002's figures at every point."""
    suite = tmp_path / "mine.yaml"
    suite.write_text(
        "name: my_drop\nrest: {hold: 0.2}\ninitial: {height: 0.5}\nsweep:\n  initial.height: [0.5, 0.9]\n"
    )
    results, out, every = tmp_path / "results", tmp_path / "reports", tmp_path / "every"
    assert sweep(suite, results).exit_code == 0
    report = ["report", "--results", str(results), "--jobs", "2"]
    done = CliRunner().invoke(app, [*report, "--out", str(out)])
    assert done.exit_code == 0, done.output
    page = (out / "family_talos_my_drop.html").read_text()
    assert 'src="forest_family_talos_my_drop.png"' in page
    assert len(list(out.glob("fig6a_my_drop_initial_height_*.png"))) == 1
    done = CliRunner().invoke(
        app, [*report, "--out", str(every), "--filmstrips", "all", "--paper-figures", "all"]
    )
    assert done.exit_code == 0, done.output
    assert len(list(every.glob("fig6a_my_drop_initial_height_*.png"))) == 2
    bad = CliRunner().invoke(app, [*report, "--out", str(tmp_path / "bad"), "--filmstrips", "some"])
    assert bad.exit_code == 2 and "error: --filmstrips" in bad.stderr and not (tmp_path / "bad").exists()
    if "no OpenGL context" in page:
        pytest.skip("no OpenGL context: filmstrips are skipped with the reason")
    runs = store.load_metrics(results)
    for folder, scope in ((out, "family"), (every, "all")):
        chosen = picks(runs, scope)
        shown = {p.name for p in folder.glob("filmstrip_*.png")}
        assert shown == {f"filmstrip_{p.run_id}.png" for p in chosen}
        text = (folder / "family_talos_my_drop.html").read_text()
        assert all(f'src="filmstrip_{p.run_id}.png"' in text for p in chosen)
    assert {(p.policy, p.role) for p in picks(runs, "all") if p.role == "typical"} == {
        ("stiff", "typical"),
        ("zero", "typical"),
    }
    family = {p.run_id for p in picks(runs, "family")}
    assert 1 < len(family) <= 3 and family <= {p.run_id for p in picks(runs, "all")}


def test_envelope_keeps_every_peak_of_a_long_series() -> None:
    """002's series are cut to 2 samples per pixel column: each bucket's smallest and largest value,
    in time order, so a one-sample landing spike and the lowest dip survive exactly."""
    from fallbench.report.figure_files import envelope

    t = np.arange(6000) * 0.0005
    y = np.sin(t * 7.0)
    y[3001], y[17] = 250.0, -80.0  # a spike and a dip of one sample each
    shown_t, shown_y = envelope(t, y, buckets=800)
    assert len(shown_y) <= 1600 and np.all(np.diff(shown_t) > 0)
    assert shown_y.max() == 250.0 and shown_t[shown_y.argmax()] == t[3001]
    assert shown_y.min() == -80.0 and shown_t[shown_y.argmin()] == t[17]
    assert envelope(t[:100], y[:100], buckets=800)[1].tolist() == y[:100].tolist()  # short: unchanged


def test_a_reshaped_fall_without_fall_time_is_skipped_with_a_note(tmp_path: Path) -> None:
    """A reshape run that fell with no fall_time (no detector saw it) stopped the whole report with
    "Axis limits cannot be NaN or Inf": now its figure is skipped and the note says why."""
    results = tmp_path / "results"
    columns = [f"q:{joint}" for joint in get_robot("talos").trajectory_joints]
    columns += [f"force:{group}" for group in TIMELINE_GROUPS]
    series = pd.DataFrame({"t": np.linspace(0.0, 1.0, 11)} | {c: np.zeros(11) for c in columns})
    for strategy in ("none", "reshape"):
        row = _row(strategy, "push", "push#s0", 0, strategy, "stiff", fell=True, fall_time=np.nan)
        store.write_run(results, strategy, {"point": "push#s0"}, row, series)
    store.consolidate(results)
    rows = store.load_metrics(results)
    figure = drawing.Figure(
        "reshape:talos:push#s0:stiff", draw_reshaped_falls, (rows, results, tmp_path, "push#s0", "stiff")
    )
    drawn = drawing.draw([figure], results, tmp_path)
    assert drawn.paths[figure.name] == []
    assert (
        drawn.notes[figure.name] == "reshaped fall push#s0, stiff: skipped, the reshape run has no fall_time"
    )


def test_sweep_figures_have_units_angles_on_polar_axes_and_the_demand_ratio_on_a_log_axis() -> None:
    import matplotlib.pyplot as plt

    from fallbench.report.sweeps import _sweep_figure

    rows = [
        _row(
            f"r{k}{seed}",
            "push",
            f"push#{k}",
            seed,
            "none",
            "stiff",
            **{"param:push.direction": d, "param:push.start": 0.1 * k},
        )
        | {"imu_peak_z": 50.0 + k + seed, "knee_limit_margin": 0.5, "torque_demand_ratio_max": 10.0**k}
        for k, d in enumerate((0.0, 90.0, 180.0, 270.0))
        for seed in range(3)
    ]
    runs = pd.DataFrame(rows)
    polar, _ = _sweep_figure(runs, "param:push.direction", "talos", "push")
    assert [ax.name for ax in polar.axes[:3]] == ["polar"] * 3
    line, _ = _sweep_figure(runs, "param:push.start", "talos", "push")
    assert line.axes[0].get_xlabel() == "push.start (s)" and line.axes[2].get_yscale() == "log"
    assert len(line.axes[0].collections) == 1  # the intervals: three seeds per value
    plt.close("all")
