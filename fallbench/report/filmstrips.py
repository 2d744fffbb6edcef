"""Which falls the report shows as filmstrips, and rendering them (skipped, with the reason, when
there is no OpenGL context)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from fallbench.report.render import RenderUnavailable, ReplayMissing, filmstrip
from fallbench.report.style import ordered
from fallbench.robots import DEFAULT_ROBOT

HEIGHT, DIRECTION = "param:initial.height", "param:push.direction"
RESHAPED_FALLS = ("push_200N", (0.0, 180.0), "stiff")  # family, push directions, policy: none vs reshape


def chosen_runs(runs: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """Caption -> runs: the 1 m drop of 002 under each policy (seed 0) on each robot, and 000/002's
    200 N front and back pushes with and without reshaping (default robot)."""
    ok = runs[(runs.status == "ok") & (runs.seed == 0)]
    chosen: dict[str, pd.DataFrame] = {}
    if HEIGHT in ok:
        drops = ok[(ok.scenario == "drop") & (ok[HEIGHT] == 1.0) & (ok.pre_impact == "none")]
        robots = drops.robot if "robot" in drops else pd.Series("", index=drops.index)
        for robot, drop in drops.groupby(robots):
            rank = {policy: i for i, policy in enumerate(ordered(drop.policy))}
            chosen[f"The 1 m drop of 002 {robot}, each gain policy".replace("  ", " ")] = drop.sort_values(
                "policy", key=lambda p: p.map(rank)
            )
    family, directions, policy = RESHAPED_FALLS
    if DIRECTION in ok:
        pushes = ok[(ok.scenario == family) & ok[DIRECTION].isin(directions) & (ok.policy == policy)]
        pushes = pushes[pushes.robot == DEFAULT_ROBOT] if "robot" in pushes else pushes
        if len(pushes):
            chosen[f"{family}, {policy}: front and back pushes, none vs reshape"] = pushes.sort_values(
                [DIRECTION, "pre_impact"]
            )
    return chosen


def render_filmstrips(runs: pd.DataFrame, results: Path, out: Path) -> tuple[dict[str, list[Path]], str]:
    """Caption -> filmstrip PNGs, and a note: empty, or why there are none."""
    strips: dict[str, list[Path]] = {}
    try:
        for caption, chosen in chosen_runs(runs).items():
            strips[caption] = [filmstrip(results, run_id, out) for run_id in chosen.run_id]
    except RenderUnavailable as exc:
        return {}, f"filmstrips skipped: {exc}"
    except ReplayMissing as exc:
        return strips, f"some filmstrips skipped: {exc}"
    return strips, ""
