"""004's top-down view of one point: the objects, the safe regions `direction` computed from its
origin, the candidates' predicted fall directions, the chosen and the actual one, and the CoM
paths of `none` and `direction` on the same fall."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Wedge
from ruamel.yaml import YAML

from fallbench.analysis.obstacles import OutcomeSettings
from fallbench.analysis.safe_regions import grown_circles, object_circle, safe_regions
from fallbench.report.figure_files import save_figure
from fallbench.results import store
from fallbench.scenario import Scenario

PLOT_RADIUS = 2.2  # m, extent of the shaded safe cones


def _scenario(results: Path, run_id: str) -> Scenario:
    spec = YAML(typ="safe", pure=True).load((store.run_dir(results, run_id) / "spec.yaml").read_text())
    return Scenario.model_validate(spec["scenario"])


def _ray(origin: np.ndarray, degrees: float, length: float) -> np.ndarray:
    """Start and end of a ray from `origin` (m) at `degrees`, as x and y rows for `plot`."""
    angle = math.radians(degrees)
    return np.c_[origin, origin + length * np.array([math.cos(angle), math.sin(angle)])]


def _draw_safe_regions(ax: Axes, scenario: Scenario, config: OutcomeSettings, origin: np.ndarray) -> None:
    """Shade the safe cones about `origin` between the grown object circles."""
    grown = grown_circles(scenario.obstacles, origin, config.robot_radius, config.consider_distance)
    for region in safe_regions(grown, origin):
        start = math.degrees(region.start)
        ax.add_patch(
            Wedge(
                origin,
                PLOT_RADIUS,
                start,
                start + math.degrees(region.width),
                color="#17becf",
                alpha=0.18,
                lw=0,
            )
        )


def _draw_objects(ax: Axes, scenario: Scenario, robot_radius: float) -> None:
    """Each object's circle, and dashed, the circle grown by the robot's radius."""
    for obstacle in scenario.obstacles:
        circle = object_circle(obstacle)
        ax.add_patch(CirclePatch(circle.centre, circle.radius, color="#8c564b", alpha=0.55))
        ax.add_patch(
            CirclePatch(
                circle.centre,
                circle.radius + robot_radius,
                fill=False,
                ls="--",
                color="#8c564b",
                lw=0.8,
            )
        )


def _draw_com_paths(ax: Axes, rows: pd.DataFrame, results: Path) -> None:
    """The CoM's path of the `none` and the `direction` run, each marked hit or clear."""
    for name, colour in (("none", "#7f7f7f"), ("direction", "#1f77b4")):
        series = store.load_timeseries(results, rows.loc[name, "run_id"])
        hit = "hit" if rows.loc[name, "obstacle_hit"] else "clear"
        ax.plot(series.com_x, series.com_y, color=colour, lw=2, label=f"CoM, {name} ({hit})")


def _draw_candidates(ax: Axes, chosen: pd.Series, origin: np.ndarray) -> None:
    """Each candidate strategy's predicted direction, green when its score is safe (<= 1), with its
    name and score."""
    candidates = sorted(json.loads(chosen.direction_candidates or "[]"), key=lambda c: c["deg"])
    level, previous = 0, -math.inf
    for candidate in candidates:
        angle = math.radians(candidate["deg"])
        level, previous = (
            (level + 1 if candidate["deg"] - previous < 8.0 else 0),
            candidate["deg"],
        )  # stagger close rays' labels
        safe = candidate["score"] is not None and candidate["score"] <= 1.0
        ax.plot(
            *_ray(origin, candidate["deg"], 1.0),
            color="#009E73" if safe else "#D55E00",  # Okabe-Ito: told apart with any colour vision
            lw=0.8,
            alpha=0.7,
        )
        ax.annotate(
            f"{candidate['name']} {candidate['score'] if candidate['score'] is not None else 'inf'}",
            origin + (1.05 + 0.13 * level) * np.array([math.cos(angle), math.sin(angle)]),
            fontsize=6,
        )


def _draw_chosen_directions(ax: Axes, chosen: pd.Series, origin: np.ndarray) -> None:
    """The chosen strategy's predicted fall direction and the desired one (theta_d), where known."""
    for value, style, label in (
        (chosen.predicted_fall_direction_deg, dict(color="black", ls="--"), "predicted (chosen)"),
        (chosen.desired_fall_direction_deg, dict(color="red"), "desired theta_d"),
    ):
        if np.isfinite(value):
            ax.plot(
                *_ray(origin, value, 1.6),
                lw=1.5,
                label=label,
                **style,
            )


def top_down_figure(runs: pd.DataFrame, results: Path, out: Path, point: str, policy: str) -> list[Path]:
    """004's view from above: objects and grown circles, safe cones about the CoM at the control
    trigger, CoM paths of none and direction, candidates' predicted directions, the chosen and
    desired directions."""
    rows = runs[(runs.point == point) & (runs.policy == policy) & (runs.status == "ok")].set_index(
        "pre_impact"
    )
    rows = store.with_timeseries(results, rows)
    if not {"none", "direction"} <= set(rows.index):
        return []
    chosen = rows.loc["direction"]
    scenario = _scenario(results, chosen.run_id)
    config = OutcomeSettings.of(scenario)
    origin = np.array([chosen.direction_origin_x, chosen.direction_origin_y])
    if not np.isfinite(origin).all():
        return []
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    _draw_safe_regions(ax, scenario, config, origin)
    _draw_objects(ax, scenario, config.robot_radius)
    _draw_com_paths(ax, rows, results)
    _draw_candidates(ax, chosen, origin)
    _draw_chosen_directions(ax, chosen, origin)
    ax.set(xlim=(-2.4, 2.4), ylim=(-2.4, 2.4), aspect="equal", xlabel="x (m)", ylabel="y (m)")
    ax.set_title(f"{point} ({policy})\ndirection chose {chosen.direction_strategy or 'nothing'}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    stem = "direction_" + "".join(c if c.isalnum() else "_" for c in point).strip("_") + f"_{policy}"
    return save_figure(fig, out, stem)
