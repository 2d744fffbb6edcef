"""The report's statistics and answer: bootstrap intervals on a known distribution, natural sort,
rankings, verdicts and changes against the unprotected fall on hand-made rows."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from fallbench.report.ranking import ranked, shown_table, verdict
from fallbench.report.stats import bootstrap, natural_sorted


def test_bootstrap_interval_is_the_central_95_percent_of_the_resampled_medians() -> None:
    """The percentile interval of the median against the bootstrap distribution computed exactly: for
    n odd and distinct values, a resample's median is at most x_(j) when at least (n + 1) / 2 of its n
    draws are, P = P(Binomial(n, j / n) >= (n + 1) / 2). With 20,000 resamples the interval's ends sit
    between that distribution's 2 and 3 % (97 and 98 %) quantiles; a 90 % interval's would be at 5 %."""
    n = 201
    sample = np.random.default_rng(7).normal(size=n)
    ordered = np.sort(sample)
    at_most = scipy.stats.binom.sf((n + 1) // 2 - 1, n, np.arange(1, n + 1) / n)  # P(median <= x_(j))

    def quantile(p: float) -> float:
        return float(ordered[np.searchsorted(at_most, p)])

    assert quantile(0.03) < quantile(0.05) and quantile(0.95) < quantile(0.97)  # the test can tell 90 %
    estimate = bootstrap(sample, resamples=20_000)
    assert estimate.value == float(np.median(sample))
    assert quantile(0.02) <= estimate.low <= quantile(0.03), (estimate.low, quantile(0.02), quantile(0.03))
    assert quantile(0.97) <= estimate.high <= quantile(0.98), (estimate.high, quantile(0.97), quantile(0.98))


def test_bootstrap_is_deterministic_and_handles_small_samples() -> None:
    sample = np.random.default_rng(1).normal(5.0, 1.0, 25)
    first, again = bootstrap(sample), bootstrap(sample)
    assert (first.value, first.low, first.high) == (again.value, again.low, again.high)
    assert first.low < first.value < first.high and first.n == 25
    for statistic in ("median", "mean"):  # runs stored in another order: the same interval
        ordered = bootstrap(sample, statistic)
        shuffled = bootstrap(np.random.default_rng(2).permutation(sample), statistic)
        assert (shuffled.low, shuffled.high) == (ordered.low, ordered.high)
    assert (
        bootstrap(sample, "mean", seed=1).low != bootstrap(sample, "mean").low
    )  # the seed is what makes it repeatable
    single = bootstrap([3.0, np.nan])
    assert single.value == 3.0 and np.isnan(single.low) and single.n == 1 and single.format() == "3 (n=1)"
    constant = bootstrap([2.0, 2.0, 2.0])
    assert (constant.low, constant.high) == (2.0, 2.0)
    fraction = bootstrap([True, False, True, True], "mean")
    # resampled means of 3 True in 4: P(<= 0.25) = 5.1 %, P(0) = 0.4 %, P(1) = 31.6 %: the 95 % interval
    assert (fraction.value, fraction.low, fraction.high) == (0.75, 0.25, 1.0)


def test_bootstrap_intervals_are_scipys_bit_for_bit() -> None:
    """report/stats.py computes scipy.stats.bootstrap's percentile interval without scipy: the same
    numbers, on samples with ties, small and large, for the median and the mean."""
    rng = np.random.default_rng(3)
    samples = [
        rng.normal(size=31),
        rng.integers(0, 3, size=12).astype(float),
        np.round(rng.exponential(size=150) * 1000, 1),
        np.array([0.0, 1.0]),
        rng.integers(-5, 6, size=47) * 0.1,
    ]
    for sample in samples:
        for statistic, function in (("median", np.median), ("mean", np.mean)):
            ours = bootstrap(sample, statistic)
            theirs = scipy.stats.bootstrap(
                (np.sort(sample),),
                function,
                n_resamples=2000,
                confidence_level=0.95,
                method="percentile",
                vectorized=True,
                rng=np.random.default_rng(0),
            ).confidence_interval
            assert (ours.low, ours.high) == (float(theirs.low), float(theirs.high)), (statistic, len(sample))


def test_natural_sort_orders_swept_values_by_number() -> None:
    labels = [
        "drop[initial.height=1.25]#s0",
        "drop[initial.height=1]#s0",
        "drop[initial.height=0.75]#s0",
        "push[push.direction=-30]#s0",
        "push[push.direction=30]#s0",
        "push[push.direction=0]#s10",
        "push[push.direction=0]#s2",
    ]
    assert natural_sorted(labels) == [
        "drop[initial.height=0.75]#s0",
        "drop[initial.height=1]#s0",
        "drop[initial.height=1.25]#s0",
        "push[push.direction=-30]#s0",
        "push[push.direction=0]#s2",
        "push[push.direction=0]#s10",
        "push[push.direction=30]#s0",
    ]


def _family(seed: int = 0) -> pd.DataFrame:
    """20 points; `reshape + zero` hits the head half as hard as the others, everything else equal."""
    rng = np.random.default_rng(seed)
    rows = []
    for point in range(20):
        for strategy, policy, head in (
            ("none", "stiff", 1000.0),
            ("none", "zero", 1000.0),
            ("reshape", "zero", 500.0),
        ):
            rows.append(
                {
                    "scenario": "fam",
                    "point": f"fam#s{point}",
                    "status": "ok",
                    "pre_impact": strategy,
                    "policy": policy,
                    "imu_peak_z": 100 + rng.normal(0, 5),
                    "contact_force_peak_head": head * (1 + rng.normal(0, 0.05)),
                    "contact_force_peak_torso": 800 + rng.normal(0, 20),
                    "knee_limit_margin": 0.5,
                    "joint_limit_hits": 0,
                    "fell": True,
                    "contact_force_peak_head_bw": head / 900,
                    "vulnerable_hits": 1 if head > 600 else 0,
                }
            )
    return pd.DataFrame(rows)


def test_ranking_puts_the_gentler_arm_first_with_intervals_and_a_clear_verdict() -> None:
    runs = _family()
    table = ranked(runs).table
    assert (table.pre_impact[0], table.policy[0]) == ("reshape", "zero")
    assert list(table.runs) == [20, 20, 20]
    head = table["head peak force (N)"][0]
    low, high = (float(x) for x in head[head.index("[") + 1 : -1].split(","))
    assert low < 500 < high and high < 900
    assert "IMU z peak, whole run (m/s²)" in table.columns  # the landing peak falls back to the whole run's
    line = verdict(runs)
    assert line.startswith("least damage: reshape + zero")
    assert "clearly less damage than the runner-up (none + " in line and ") on head peak force" in line
    same = _family().assign(contact_force_peak_head=1000.0, vulnerable_hits=1)
    assert "no clear winner" in verdict(same)


def _arms_family(values: dict[tuple[str, str], dict[str, float]], points: int = 8) -> pd.DataFrame:
    """Runs of the given arms at `points` points, one seed: each measure its value plus a spread
    common to every arm (point k adds k %), so that the medians keep the values' order."""
    rows = []
    for point in range(points):
        for (strategy, policy), measures in values.items():
            row = {"scenario": "fam", "point": f"fam#s{point}", "seed": 0, "status": "ok"}
            row |= {"pre_impact": strategy, "policy": policy}
            row |= {k: v * (1 + point / 100) if k != "fell" else v for k, v in measures.items()}
            rows.append(row)
    return pd.DataFrame(rows)


def test_verdict_lists_only_measures_on_which_the_named_arm_is_clearly_better() -> None:
    """The best mean rank is clearly worse than the runner-up on torso: never read as 'clear of'."""
    runs = _arms_family(
        {
            ("none", "stiff"): {
                "imu_peak_z": 100,
                "contact_force_peak_head": 1000,
                "contact_force_peak_torso": 800,
            },
            ("none", "zero"): {
                "imu_peak_z": 101,
                "contact_force_peak_head": 1001,
                "contact_force_peak_torso": 790,
            },
            ("reshape", "zero"): {
                "imu_peak_z": 99,
                "contact_force_peak_head": 999,
                "contact_force_peak_torso": 1200,
            },
        }
    )
    line = verdict(runs)
    assert line.startswith("least damage: reshape + zero")
    assert "not clearly better than the runner-up (none + stiff) on any measure: no clear winner" in line
    assert line.endswith("; clearly more on torso peak force")


def test_a_tie_on_mean_rank_is_called_a_tie_whatever_the_row_order() -> None:
    runs = _arms_family(
        {
            ("none", "stiff"): {"imu_peak_z": 130, "contact_force_peak_head": 1300},
            ("none", "zero"): {"imu_peak_z": 50, "contact_force_peak_head": 1200},
            ("reshape", "zero"): {"imu_peak_z": 120, "contact_force_peak_head": 500},
        }
    )
    for order in (runs, runs.iloc[::-1]):
        assert verdict(order).startswith(
            "a tie: none + zero, reshape + zero share the best mean rank (1.5 of 3)"
        )


def test_verdict_with_one_run_per_arm_and_with_a_single_arm() -> None:
    arms = {
        ("none", "stiff"): {"imu_peak_z": 100, "contact_force_peak_head": 1000},
        ("none", "zero"): {"imu_peak_z": 90, "contact_force_peak_head": 900},
    }
    line = verdict(_arms_family(arms, points=1))
    assert line.startswith("least damage: none + zero (mean rank 1 of 2 over 2 measures, 1 run)")
    assert line.endswith("one run each, so no interval: a ranking of single falls, not of distributions")
    alone = _arms_family({("none", "zero"): arms[("none", "zero")]})
    assert verdict(alone) == "only none + zero ran"


def test_an_arm_clearly_worse_than_none_stiff_on_falls_is_never_the_winner() -> None:
    """reshape + stiff has the best mean rank (gentler on every force) but falls in 15 of 16
    pairs where none + stiff falls in 9: the verdict names the next arm and says why."""
    runs = _arms_family(
        {
            ("none", "stiff"): {
                "imu_peak_z": 100,
                "contact_force_peak_head": 1000,
                "contact_force_peak_torso": 800,
            },
            ("none", "zero"): {
                "imu_peak_z": 101,
                "contact_force_peak_head": 1001,
                "contact_force_peak_torso": 801,
            },
            ("reshape", "stiff"): {
                "imu_peak_z": 50,
                "contact_force_peak_head": 500,
                "contact_force_peak_torso": 400,
            },
        },
        points=16,
    )
    falls = {("none", "stiff"): 9, ("none", "zero"): 9, ("reshape", "stiff"): 15}
    for (strategy, policy), count in falls.items():
        arm = (runs.pre_impact == strategy) & (runs.policy == policy)
        runs.loc[arm, "fell"] = [k < count for k in range(16)]
    table = ranked(runs).table
    assert (table.pre_impact[0], table.policy[0]) == ("reshape", "stiff")
    assert table["clearly worse than none + stiff on"][0] == "fell"
    line = verdict(runs)
    assert line.startswith("least damage: none + stiff (mean rank")
    assert (
        "; reshape + stiff ranks higher but is clearly worse than none + stiff on fell (paired change 0.375 ["
        in line
    )


def test_an_arm_that_makes_the_robot_fall_where_it_survives_is_never_the_winner() -> None:
    """reshape + stiff is gentler on every force and falls in 3 of the 7 pairs none + stiff
    survives, never survives where it falls: the interval of its change in `fell` reaches 0
    (not clearly worse), yet the verdict passes over it and says why; 1 fall made of 30 survived
    (3 %) is within the 5 % allowed."""
    forces = {"imu_peak_z": 100, "contact_force_peak_head": 1000, "contact_force_peak_torso": 800}
    gentle = {key: value / 2 for key, value in forces.items()}
    runs = _arms_family({("none", "stiff"): forces, ("reshape", "stiff"): gentle}, points=16)
    reference = (runs.pre_impact == "none").to_numpy()
    runs.loc[reference, "fell"] = [k < 9 for k in range(16)]
    runs.loc[~reference, "fell"] = [k < 12 for k in range(16)]
    done = ranked(runs)
    assert (done.table.pre_impact[0], done.table.policy[0]) == ("reshape", "stiff")
    assert done.harm[("reshape", "stiff")][0].evidence.startswith("made the robot fall in 3 of the 7 runs")
    assert done.table["clearly worse than none + stiff on"][0] == "made to fall (3 of 7)"
    line = verdict(runs)
    assert line.startswith("least damage: none + stiff (mean rank")
    assert (
        "; reshape + stiff ranks higher but made the robot fall in 3 of the 7 runs none + stiff survives"
        in line
    )

    runs = _arms_family({("none", "stiff"): forces, ("reshape", "stiff"): gentle}, points=40)
    reference = (runs.pre_impact == "none").to_numpy()
    runs.loc[reference, "fell"] = [k < 10 for k in range(40)]
    runs.loc[~reference, "fell"] = [k < 11 for k in range(40)]
    assert verdict(runs).startswith("least damage: reshape + stiff")


def test_arms_with_the_same_falls_pair_by_pair_are_one_row() -> None:
    """A strategy that chose to do nothing is its policy without it: one row, never a winner by
    row order."""
    base = {"imu_peak_z": 100, "contact_force_peak_head": 1000}
    runs = _arms_family(
        {
            ("none", "stiff"): base,
            ("none", "zero"): {"imu_peak_z": 90, "contact_force_peak_head": 900},
            ("direction", "zero"): {"imu_peak_z": 90, "contact_force_peak_head": 900},
        },
        points=5,
    )
    runs["direction_strategy"] = np.where(runs.pre_impact == "direction", "no_action", None)
    table = ranked(runs).table
    assert list(zip(table.pre_impact, table.policy)) == [("none", "zero"), ("none", "stiff")]
    assert list(shown_table(ranked(runs)).arm) == ["none + zero = direction + zero", "none + stiff"]
    assert table["same falls as"][0] == "direction + zero (5 runs; direction chose no_action in 5/5)"
    assert verdict(runs).startswith("least damage: none + zero = direction + zero (mean rank 1 of 2")


@pytest.mark.slow
def test_report_pages_from_a_small_synthetic_store(tmp_path) -> None:
    """Overview answers first, per robot and family, links its figures; one page per family;
    points in natural order; no filmstrips without drop or push runs, and no error."""
    from fallbench.report import build_report
    from fallbench.results import store

    rng = np.random.default_rng(3)
    results, out = tmp_path / "results", tmp_path / "reports"
    n = 0
    for robot in ("talos", "g1"):
        for family in ("alpha", "beta"):
            for x in (1.25, 0.75, 1.0):
                for seed in range(3):
                    for strategy, policy in (("none", "stiff"), ("none", "zero"), ("reshape", "zero")):
                        n += 1
                        row = {
                            "run_id": f"r{n:04d}",
                            "robot": robot,
                            "scenario": family,
                            "point": f"{family}[x={x:g}]#s{seed}",
                            "status": "ok",
                            "error": "",
                            "pre_impact": strategy,
                            "policy": policy,
                            "seed": seed,
                            "param:x": x,
                            "imu_peak_z": 100 + 10 * rng.random(),
                            "contact_force_peak_head": 1000 * rng.random(),
                            "contact_force_peak_torso": 500.0,
                            "knee_limit_margin": 0.3,
                            "joint_limit_hits": 0,
                            "torque_demand_ratio_max": 1.0,
                            "contact_force_peak": 2000.0,
                            "fell": True,
                            "first_impact_group": "hands",
                            "first_impact_safe": True,
                            "obstacle_force_peak": 0.0,
                            "landing_error": np.nan,
                            "time_to_first_impact": 0.5,
                            "contact_force_peak_bw": 2.0,
                            "vulnerable_hits": 0,
                            "impact_time": 0.5,
                        }
                        store.write_run(results, row["run_id"], {"point": row["point"]}, row, None)
    store.consolidate(results)
    paths = build_report(results, out, progress=False)
    page = (out / "index.html").read_text()
    assert "data:image" not in page and len(page) < 200_000
    assert page.index("What hurts the robot least") < page.index("Claims of the papers")
    verdicts = page.count("<p class='verdict'>least damage:") + page.count("<p class='verdict'>a tie:")
    assert verdicts == 4  # one per robot and family (random forces: ties happen)
    assert "Robot g1" in page and "Robot talos" in page
    assert "head peak force (N)" in page and "[" in page
    family = out / "family_talos_alpha.html"
    assert family in paths and (out / "family_g1_beta.html").exists()
    text = family.read_text()
    assert "Change against the unprotected fall" in text and 'src="sweep_alpha_x.png"' in text
    assert "sweep_alpha_x_g1.png" not in text  # the other robot's sweep figure: on its own page
    assert "002 (Samy, Bouyarmane &amp; Kheddar 2017)" in page
    assert not list(out.glob("filmstrip_*.png"))


def test_arms_have_one_name_everywhere() -> None:
    from fallbench.report.names import arm_name

    assert arm_name("none", "adaptive_qp") == "none + adaptive_qp"
    assert arm_name("onnx", "-") == "onnx (learned)"
