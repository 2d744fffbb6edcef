"""004's direction-changing fall control in the report: top-down plots as in 004's figures, hit
rates of `none` vs `direction` on the same falls, and 004's claims with N/M counts."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from fallbench.report.figure_files import save_figure
from fallbench.report.papers.direction_judge import (
    authority_runs,
    authority_table,
    judge_hits,
    judged_table,
    variants,
    within_authority_claim,
    without_empty_settings,
)
from fallbench.report.papers.direction_top_down import top_down_figure
from fallbench.report.papers.figures_004 import expected_choices, mirrors
from fallbench.report.selection import free_space

PAIR_KEYS = ["point", "policy"]
DIRECTION_PARAM = "param:policy_params.direction."
PREDICTOR_PARAM = DIRECTION_PARAM + "predictor"
MAX_YAW_ROWS = 4  # layout turns per scenario shown as rows of their own (more: one row, "all")


def _class(label: str) -> str:
    """no_action / lift_leg / take_step / take_step+pis ... from e.g. take_step_right+pis."""
    return label.replace("_left", "").replace("_right", "")


def paired(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (point, policy) run with both `none` and `direction`: outcomes side by side."""
    ok = runs[
        (runs.status == "ok") & runs.get("obstacle_hit", pd.Series(index=runs.index, dtype=object)).notna()
    ]
    none = ok[ok.pre_impact == "none"].set_index(PAIR_KEYS)
    direction = ok[ok.pre_impact == "direction"].set_index(PAIR_KEYS)
    both = none.index.intersection(direction.index)
    if not len(both):
        return pd.DataFrame()
    none, direction = none.loc[both], direction.loc[both]
    frame = pd.DataFrame(
        {
            "scenario": direction.scenario,
            "fell": none.fall_time.notna(),
            "none_hit": none.obstacle_hit.astype(bool),
            "direction_hit": direction.obstacle_hit.astype(bool),
            "none_safe": none.actual_in_safe_region.astype(bool),
            "direction_safe": direction.actual_in_safe_region.astype(bool),
            "strategy": direction.direction_strategy.fillna(""),
            "error_deg": direction.fall_direction_error_deg,
            "plan_ms": direction.direction_plan_ms,
            "step_ms": direction.get("direction_step_ms_median"),
            "predicted_score": direction.predicted_score,
            "step_completed": direction.get("step_completed"),
            "layout_yaw": direction.get("param:layout_yaw", pd.Series(0.0, index=direction.index)).fillna(
                0.0
            ),
            "predictor": direction.get(PREDICTOR_PARAM, pd.Series("pendulum", index=direction.index)).fillna(
                "pendulum"
            ),
            "settings": _swept_settings(direction),
            "need_deg": none.get("needed_deflection_deg", pd.Series(np.nan, index=none.index)),
            "none_run_id": none.get("run_id"),
            "direction_run_id": direction.get("run_id"),
        }
    )
    return frame.reset_index()


def _ratio(n: int, m: int) -> str:
    return f"{n}/{m}" + (f" ({100 * n / m:.0f} %)" if m else "")


def _swept_settings(direction: pd.DataFrame) -> pd.Series:
    """Each run's swept `direction` parameters but the predictor, e.g. "cone_margin=12,
    when_none_safe=best" ("" when none is swept), so that a sweep's variants are judged apart."""
    columns = sorted(c for c in direction if c.startswith(DIRECTION_PARAM) and c != PREDICTOR_PARAM)

    def label(run: pd.Series) -> str:
        values = {
            column.removeprefix(DIRECTION_PARAM): run[column] for column in columns if pd.notna(run[column])
        }
        return ", ".join(
            f"{name}={value:g}" if isinstance(value, float) else f"{name}={value}"
            for name, value in values.items()
        )

    return direction.apply(label, axis=1) if columns else pd.Series("", index=direction.index)


def hit_table(pairs: pd.DataFrame) -> pd.DataFrame:
    """Per scenario and layout turn (`layout_yaw`): object hits of `none` vs `direction`, strategies
    chosen, prediction error and planning time."""
    rows = []
    yaws = pairs.groupby("scenario").layout_yaw.transform("nunique")
    pairs = variants(pairs).assign(layout_yaw=pairs.layout_yaw.where(yaws <= MAX_YAW_ROWS, "all"))
    for (scenario, predictor, settings, yaw), group in pairs.groupby(
        ["scenario", "predictor", "settings", "layout_yaw"]
    ):
        hits = group[group.none_hit]
        clear = group[~group.none_hit]
        rows.append(
            {
                "scenario": scenario,
                "predictor": predictor,
                "settings": settings,
                "layout_yaw (deg)": yaw,
                "runs": len(group),
                "falls detected": int(group.fell.sum()),
                "none hits object": _ratio(int(group.none_hit.sum()), len(group)),
                "direction hits object": _ratio(int(group.direction_hit.sum()), len(group)),
                "none hits avoided by direction": _ratio(int((~hits.direction_hit).sum()), len(hits)),
                "none clear kept clear": _ratio(int((~clear.direction_hit).sum()), len(clear)),
                "direction falls toward a safe region": _ratio(int(group.direction_safe.sum()), len(group)),
                "strategies chosen": ", ".join(
                    f"{k} {v}" for k, v in group.strategy.map(_class).value_counts().items()
                ),
                "prediction error median (deg)": round(float(group.error_deg.median()), 1),
                "prediction error median, Take a Step (deg)": round(
                    float(group[group.strategy.str.startswith("take_step")].error_deg.median()), 1
                ),
                "plan median (ms)": round(float(group.plan_ms.median()), 1),
                "control step median (ms)": round(float(group.step_ms.median()), 2)
                if group.step_ms.notna().any()
                else math.nan,
            }
        )
    return without_empty_settings(pd.DataFrame(rows))


def _claim(text: str, n: int, m: int, holds: bool | None, extra: str = "") -> dict[str, str]:
    """One row of 004's claims: `n` of `m` cases where it holds; n/a without cases."""
    verdict = "n/a" if holds is None or m == 0 else ("holds" if holds else "does not hold")
    return {"claim (004)": text, "verdict": verdict, "N/M": _ratio(n, m) + (f"; {extra}" if extra else "")}


def _avoidance_claims(pairs: pd.DataFrame) -> list[dict[str, str]]:
    """Fig. 1: direction avoids the objects none hits, keeps none's safe falls safe, and does so by
    steering the fall toward a safe region that the fall model (grown circles) keeps clear."""
    hits, clear = pairs[pairs.none_hit], pairs[~pairs.none_hit]
    avoided = int((~hits.direction_hit).sum())
    kept_clear = int((~clear.direction_hit).sum())
    steered = int(hits.direction_safe.sum())
    toward_safe = pairs[pairs.direction_safe]
    untouched = int((~toward_safe.direction_hit).sum())
    return [
        _claim(
            "direction avoids the objects that none hits (Fig. 1); holds at >= 50 %",
            avoided,
            len(hits),
            avoided >= 0.5 * len(hits),
        ),
        _claim(
            "direction keeps safe none falls safe; holds at >= 95 %",
            kept_clear,
            len(clear),
            kept_clear >= 0.95 * len(clear),
        ),
        # the two halves of the first claim: steering the fall, and the fall model (grown circles) keeping it clear
        _claim(
            "direction turns the falls that none makes hit into falls toward a safe region (actual direction, "
            "eqs. 2-4); holds at >= 50 %",
            steered,
            len(hits),
            steered >= 0.5 * len(hits),
        ),
        _claim(
            "a direction fall toward a safe region touches no object (objects as circles grown by robot_radius); "
            "holds at >= 95 %",
            untouched,
            len(toward_safe),
            untouched >= 0.95 * len(toward_safe),
        ),
    ]


def _strategy_claims(pairs: pd.DataFrame) -> list[dict[str, str]]:
    """Figs. 6 and 9: the strategies chosen, each safe at least once; No Action and whole-body IS safe."""
    # No Action predicted safe, not chosen for want of a safe candidate (`when_none_safe`)
    na = pairs[(pairs.strategy == "no_action") & (pairs.predicted_score <= 1.0)]
    na_safe = int((~na.direction_hit).sum())
    chosen = pairs.strategy.map(_class)
    classes = {
        "no_action": chosen == "no_action",
        "lift_leg": chosen.str.startswith("lift_leg"),
        "take_step": chosen.str.startswith("take_step"),
        "whole-body IS": chosen.str.endswith("+wbis"),
    }
    safe_counts = {k: int((m & ~pairs.direction_hit).sum()) for k, m in classes.items()}
    chosen_and_safe = sum(1 for k in classes if safe_counts[k] > 0)
    wbis = pairs[chosen.str.endswith("+wbis")]
    rescued = int((~wbis.direction_hit).sum())
    return [
        _claim(
            "when No Action is chosen (predicted safe), the fall is safe (Fig. 6)",
            na_safe,
            len(na),
            na_safe == len(na),
        ),
        _claim(
            "No Action, Lift a Leg, Take a Step and whole-body IS are each chosen and safe at least once",
            chosen_and_safe,
            len(classes),
            chosen_and_safe == len(classes),
            ", ".join(f"{k} chosen {int(m.sum())}, safe {safe_counts[k]}" for k, m in classes.items()),
        ),
        _claim(
            "whole-body inertia shaping rescues a predicted-unsafe fall (Fig. 9)",
            rescued,
            len(wbis),
            rescued >= 1,
        ),
    ]


def _prediction_claims(pairs: pd.DataFrame) -> list[dict[str, str]]:
    """Sec. VI: the inverted-pendulum prediction's error, and incomplete steps against completed ones."""
    errors = pairs.error_deg.dropna()
    steps = pairs[pairs.strategy.map(_class).str.startswith("take_step") & pairs.step_completed.notna()]
    done, undone = steps[steps.step_completed.astype(bool)], steps[~steps.step_completed.astype(bool)]
    return [
        _claim(
            "prediction error median <= 15 deg (inverted-pendulum prediction, Sec. VI)",
            int((errors <= 15).sum()),
            len(errors),
            bool(len(errors)) and float(errors.median()) <= 15,
            f"median {errors.median():.1f} deg" if len(errors) else "",
        ),
        _claim(
            "incomplete steps fail more often than completed ones (Sec. VI)",
            int(undone.direction_hit.sum()),
            len(undone),
            None
            if not len(done) or not len(undone)
            else undone.direction_hit.mean() > done.direction_hit.mean(),
            f"completed steps: {int(done.direction_hit.sum())}/{len(done)} hit",
        ),
    ]


def claims(runs: pd.DataFrame, pairs: pd.DataFrame, expected: dict[str, str] | None = None) -> pd.DataFrame:
    """004's qualitative claims against our runs (thresholds are ours: 004 reports single cases);
    `expected`: the figure mirrors' families -> 004's choice (figures_004.expected_choices)."""
    if pairs.empty:
        return pd.DataFrame()
    rows = _avoidance_claims(pairs) + _strategy_claims(pairs) + _prediction_claims(pairs)
    return pd.DataFrame(rows + _ablation(runs) + _mirrors(pairs, expected or {}))


def _ablation(runs: pd.DataFrame) -> list[dict[str, str]]:
    """Fig. 10: each strategy forced on the same fall; only Take a Step + partial IS is safe."""
    mode = "param:policy_params.direction.mode"
    if mode not in runs:
        return []
    forced = runs[(runs.status == "ok") & runs[mode].notna() & (runs.pre_impact == "direction")]
    if forced.empty:
        return []
    hit = forced.groupby(mode).obstacle_hit.agg(["sum", "count"])
    pis_safe = "take_step_pis" in hit.index and hit.loc["take_step_pis", "sum"] == 0
    others_hit = all(hit.loc[m, "sum"] > 0 for m in ("no_action", "take_step") if m in hit.index)
    numbers = ", ".join(f"{m}: {int(r['sum'])}/{int(r['count'])} hit" for m, r in hit.iterrows())
    return [
        {
            "claim (004)": "Fig. 10: Take a Step + partial IS is safe where No Action and Take a Step are not",
            "verdict": "holds" if pis_safe and others_hit else "does not hold",
            "N/M": numbers,
        }
    ]


def _mirrors(pairs: pd.DataFrame, expected: dict[str, str]) -> list[dict[str, str]]:
    """Each figure mirror picks 004's strategy (`expected`: family -> 004's choice, figures_004.py)."""
    cases = pairs[pairs.scenario.isin(expected)]
    if cases.empty:
        return []
    picks = (
        cases.assign(cls=cases.strategy.map(_class)).groupby("scenario").cls.agg(lambda s: s.mode().iloc[0])
    )
    match = sum(picks.get(k, "").startswith(v) for k, v in expected.items() if k in picks)
    numbers = "; ".join(f"{k}: {picks[k]} (004: {v})" for k, v in expected.items() if k in picks)
    return [
        {
            "claim (004)": "the figure mirrors pick 004's strategies (Figs. 1, 6-9)",
            "verdict": "holds" if match == len(picks) else "does not hold",
            "N/M": f"{match}/{len(picks)}; {numbers}",
        }
    ]


def variant_label(pairs: pd.DataFrame) -> pd.Series:
    """Per pair, its scenario, then (one per line) a predictor other than 004's pendulum and each
    swept setting: the hit-rate figure's bar labels."""
    pairs = variants(pairs)
    predictor = ("\n" + pairs.predictor).where(pairs.predictor != "pendulum", "")
    settings = ("\n" + pairs.settings.str.replace(", ", "\n")).where(pairs.settings != "", "")
    return pairs.scenario + predictor + settings


def hit_rate_figure(pairs: pd.DataFrame, out: Path) -> list[Path]:
    """Share of falls hitting an object, none vs direction, per scenario and variant (a predictor
    other than 004's pendulum, swept settings)."""
    if pairs.empty:
        return []
    label = variant_label(pairs)
    rates = pairs.assign(label=label).groupby("label")[["none_hit", "direction_hit"]].mean() * 100
    longest = max(len(line) for text in rates.index for line in text.split("\n"))  # characters
    per_bar = max(1.2, 0.075 * longest)  # inches: room for the label's longest line
    fig, ax = plt.subplots(figsize=(max(5, per_bar * len(rates)), 3.5 + 0.3 * label.str.count("\n").max()))
    x = np.arange(len(rates))
    ax.bar(x - 0.2, rates.none_hit, 0.4, color="#7f7f7f", label="none")
    ax.bar(x + 0.2, rates.direction_hit, 0.4, color="#1f77b4", label="direction")
    ax.set_xticks(x, rates.index, fontsize=7)
    ax.set(ylabel="falls hitting an object (%)", ylim=(0, 105), title="Object hits: none vs direction (004)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return save_figure(fig, out, "direction_hit_rates")


def direction_report(
    runs: pd.DataFrame, results: Path, out: Path
) -> tuple[list[Path], dict[str, pd.DataFrame]]:
    authority = authority_table(authority_runs(runs, results))
    authority_tables = (
        {}
        if authority.empty
        else {
            "Steering authority in free space (deflection from none's fall, deg; scenarios/direction_authority.yaml)": authority
        }
    )
    pairs = paired(runs)
    # the authority suite's forced runs in free space are measurements, not falls to judge
    free = set(runs.loc[free_space(runs), "scenario"])
    pairs = pairs[~pairs.scenario.isin(free)] if not pairs.empty else pairs
    if pairs.empty:
        return [], authority_tables
    paths = hit_rate_figure(pairs, out)
    hits = judge_hits(pairs, results, authority)
    policy = "stiff" if (pairs.policy == "stiff").any() else pairs.policy.iloc[0]
    found = mirrors(runs, results)
    cases = sorted(pairs[pairs.scenario.isin(found)].point.unique())
    for point in cases:
        paths += top_down_figure(runs, results, out, point, policy)
    tables = {
        "Object hits, none vs direction (004)": hit_table(pairs),
        "Claims of 004": pd.concat(
            [claims(runs, pairs, expected_choices(runs, found)), pd.DataFrame(within_authority_claim(hits))]
        ),
    }
    tables |= authority_tables
    if not authority.empty:
        tables[
            "004 judged where steering can matter (hits whose needed deflection is within the authority)"
        ] = judged_table(pairs, hits)
    return paths, tables
