"""The direction report's tables on hand-made rows: pairs of none/direction runs, hit counts and
the claims' N/M."""

from __future__ import annotations

import pandas as pd

from fallbench.report.papers.direction import claims, hit_table, paired, variant_label


def _runs() -> pd.DataFrame:
    rows = []
    # (point, none hits, direction hits, direction strategy)
    for point, none_hit, direction_hit, strategy in [
        ("a", True, False, "take_step_left+pis"),
        ("b", True, True, "lift_leg_right+pis"),
        ("c", False, False, "no_action"),
        ("d", True, False, "take_step_right+wbis"),
    ]:
        common = {
            "point": point,
            "policy": "stiff",
            "scenario": "dir_x",
            "status": "ok",
            "fall_time": 0.2,
            "param:layout_yaw": 90.0,
        }
        rows.append(
            common | {"pre_impact": "none", "obstacle_hit": none_hit, "actual_in_safe_region": not none_hit}
        )
        rows.append(
            common
            | {
                "pre_impact": "direction",
                "obstacle_hit": direction_hit,
                "actual_in_safe_region": not direction_hit,
                "direction_strategy": strategy,
                "fall_direction_error_deg": 10.0 if point != "b" else 40.0,
                "direction_plan_ms": 50.0,
                "direction_step_ms_median": 2.0,
                "predicted_score": 0.5,
                "step_completed": (point == "a") if strategy.startswith("take_step") else None,
            }
        )
    return pd.DataFrame(rows)


def test_hit_table_counts_avoided_and_kept_falls() -> None:
    table = hit_table(paired(_runs())).iloc[0]
    assert table["layout_yaw (deg)"] == 90.0 and table["runs"] == 4
    assert table["none hits object"] == "3/4 (75 %)" and table["direction hits object"] == "1/4 (25 %)"
    assert (
        table["none hits avoided by direction"] == "2/3 (67 %)"
        and table["none clear kept clear"] == "1/1 (100 %)"
    )
    assert table["prediction error median (deg)"] == 10.0


def test_claims_give_n_of_m() -> None:
    verdicts = claims(_runs(), paired(_runs())).set_index("claim (004)")
    avoided = verdicts.loc["direction avoids the objects that none hits (Fig. 1); holds at >= 50 %"]
    assert avoided.verdict == "holds" and avoided["N/M"].startswith("2/3")
    wbis = verdicts.loc["whole-body inertia shaping rescues a predicted-unsafe fall (Fig. 9)"]
    assert wbis.verdict == "holds" and wbis["N/M"].startswith("1/1")
    error = verdicts.loc["prediction error median <= 15 deg (inverted-pendulum prediction, Sec. VI)"]
    assert error.verdict == "holds" and error["N/M"].startswith("3/4")


def test_claims_separate_steering_from_contact() -> None:
    """A direction fall toward a safe region that still touches an object (point b) counts as steered
    but not clear."""
    runs = _runs()
    runs.loc[(runs.point == "b") & (runs.pre_impact == "direction"), "actual_in_safe_region"] = True
    pairs = paired(runs)
    assert hit_table(pairs).iloc[0]["direction falls toward a safe region"] == "4/4 (100 %)"
    verdicts = claims(runs, pairs).set_index("claim (004)")
    steered = verdicts.loc[[c for c in verdicts.index if c.startswith("direction turns the falls")][0]]
    assert steered.verdict == "holds" and steered["N/M"].startswith("3/3")
    clear = verdicts.loc[
        [c for c in verdicts.index if c.startswith("a direction fall toward a safe region")][0]
    ]
    assert clear.verdict == "does not hold" and clear["N/M"].startswith("3/4")


def test_swept_direction_parameters_label_each_pair_but_the_predictor() -> None:
    runs = _runs()
    swept = {"a": (12.0, "best"), "b": (12.0, "no_action"), "c": (0.0, "best"), "d": (None, None)}
    runs["param:policy_params.direction.cone_margin"] = runs.point.map(lambda p: swept[p][0])
    runs["param:policy_params.direction.when_none_safe"] = runs.point.map(lambda p: swept[p][1])
    runs["param:policy_params.direction.predictor"] = "rollout"
    pairs = paired(runs).set_index("point")
    assert pairs.settings.to_dict() == {
        "a": "cone_margin=12, when_none_safe=best",
        "b": "cone_margin=12, when_none_safe=no_action",
        "c": "cone_margin=0, when_none_safe=best",
        "d": "",
    }
    assert (pairs.predictor == "rollout").all()
    assert len(hit_table(pairs.reset_index())) == 4  # one row per variant
    labels = variant_label(pairs.reset_index()).tolist()
    assert (
        labels[0] == "dir_x\nrollout\ncone_margin=12\nwhen_none_safe=best" and labels[3] == "dir_x\nrollout"
    )
    assert variant_label(paired(_runs())).tolist() == ["dir_x"] * 4
    assert "settings" not in hit_table(paired(_runs()))


def test_no_action_chosen_for_want_of_a_safe_candidate_is_not_judged_as_predicted_safe() -> None:
    """Fig. 6's claim is about No Action predicted safe; `when_none_safe: no_action` also chooses it
    when nothing is, and such falls (point e, hit) are left out of it."""
    runs = _runs()
    extra = runs[runs.point == "c"].assign(point="e")
    extra.loc[:, "obstacle_hit"] = True
    extra.loc[extra.pre_impact == "direction", "predicted_score"] = 1.5
    runs = pd.concat([runs, extra], ignore_index=True)
    verdicts = claims(runs, paired(runs)).set_index("claim (004)")
    assert verdicts.loc[
        "when No Action is chosen (predicted safe), the fall is safe (Fig. 6)", "N/M"
    ].startswith("1/1")
