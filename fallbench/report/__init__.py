"""`fallbench report`: the papers' figures, sweep comparisons, a claims table, index.html and summary.md."""

from __future__ import annotations

import base64
import html
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from fallbench import store
from fallbench.report.claims import claims_table, verdict_matrix
from fallbench.report.direction import direction_report
from fallbench.report.preimpact import preimpact_report
from fallbench.report.figures import gains_figure, imu_figure, knee_figure, torque_figure
from fallbench.report.sensitivity import sensitivity_figure, sensitivity_runs, sensitivity_table
from fallbench.report.sweeps import distribution_figure, median_table, parameter_figures
from fallbench.report.grouping import with_robot


def _leg(robot: str) -> tuple[dict[str, str], tuple[float, float], dict[str, float]]:
    """A robot's right-leg pitch joints, its knee range (rad, from the URDF) and their torque limits (Nm)."""
    from fallbench.scenario import Scenario
    from fallbench.world import build_world

    world = build_world(Scenario(name="limits", duration=1.0, robot=robot))
    leg = world.robot.leg_pitch("right")
    low, high = world.joint_range[world.joint_names.index(leg["knee"])]
    return leg, (float(low), float(high)), {j: float(world.torque_limit[world.joint_names.index(j)]) for j in leg.values()}


def paper_figures(runs: pd.DataFrame, results: Path, out: Path, progress: bool) -> dict[str, list[Path]]:
    """Figs. 4, 5, 6a, 6b for each drop or push scenario point with more than one policy, as in
    002: gain policies alone (pre-impact strategy `none`)."""
    figures: dict[str, list[Path]] = {}
    ok = runs[(runs.status == "ok") & runs.scenario.str.contains("drop|push") & (runs.pre_impact == "none")]
    points = [(point, group) for point, group in ok.groupby("point") if group.policy.nunique() > 1]
    for point, group in tqdm(points, desc="figures", unit="point", disable=not progress):
        leg, knee_limits, limits = _leg(group.robot.iloc[0])
        series = {row.policy: store.load_timeseries(results, row.run_id) for row in group.itertuples()}
        stem = "".join(c if c.isalnum() else "_" for c in point).strip("_")
        paths = imu_figure(series, group, point, out, f"fig6a_{stem}")
        paths += knee_figure(series, group, knee_limits, point, out, f"fig6b_{stem}", leg)
        paths += torque_figure(series, group, limits, point, out, f"fig4_{stem}", leg)
        if "adaptive_qp" in series:
            impact = group.loc[group.policy == "adaptive_qp", "impact_time"].iloc[0]
            paths += gains_figure(series["adaptive_qp"], impact, point, out, f"fig5_{stem}", leg)
        figures[point] = paths
    return figures


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode()
    return f'<img src="data:image/png;base64,{data}" alt="{html.escape(path.stem)}" style="max-width:100%">'


def build_report(results: Path, out: Path, progress: bool = True) -> list[Path]:
    runs = store.load_metrics(results)
    if runs.empty:
        raise FileNotFoundError(f"{results}: the results store has no runs")
    runs = with_robot(runs)
    out.mkdir(parents=True, exist_ok=True)
    figures = paper_figures(runs, results, out, progress)
    sweep_paths = distribution_figure(runs[runs.status == "ok"], out) + parameter_figures(runs[runs.status == "ok"], out)
    pre_paths, pre_tables = preimpact_report(runs, results, out)
    swept = sensitivity_runs(runs)
    sensitivity_paths = sensitivity_figure(swept, out)
    sensitivity = sensitivity_table(swept) if len(swept) else pd.DataFrame()
    direction_paths, direction_tables = direction_report(runs, results, out)
    pre_paths, pre_tables = pre_paths + direction_paths, pre_tables | direction_tables
    medians = median_table(runs)
    claims = claims_table(runs)
    verdicts = verdict_matrix(claims)
    failed = runs[runs.status != "ok"][["point", "policy", "status", "error"]]

    summary = ["# fallbench report", "", f"{len(runs)} runs from `{results}`; {len(failed)} failed or diverged.", "",
               "## Claims of 002 Sec. VI", "", verdicts.to_markdown(index=False) if len(claims) else "(no drop runs)", "",
               claims.to_markdown(index=False) if len(claims) else "", "",
               "## Pre-impact strategies (none vs reshape, none vs direction)", ""]
    for title, table in pre_tables.items():
        summary += [f"### {title}", "", table.to_markdown(index=False) if len(table) else "(no runs)", ""]
    if len(sensitivity):
        summary += ["## Sensitivity to the baseline stiffness (medians per gain scale)", "",
                    sensitivity.round(3).to_markdown(index=False), ""]
    summary += ["## Medians per scenario, strategy and policy", "", medians.round(3).to_markdown(), ""]
    if len(failed):
        summary += ["## Failed runs", "", failed.to_markdown(index=False), ""]
    summary += ["## Files", ""] + [f"- `{p.name}`" for paths in figures.values() for p in paths if p.suffix == ".png"]
    summary += [f"- `{p.name}`" for p in sweep_paths + pre_paths + sensitivity_paths if p.suffix == ".png"]
    (out / "summary.md").write_text("\n".join(summary) + "\n")

    body = [f"<h1>fallbench report</h1><p>{len(runs)} runs from <code>{html.escape(str(results))}</code>; "
            f"{len(failed)} failed or diverged.</p>", "<h2>Claims of 002 Sec. VI</h2>",
            verdicts.to_html(index=False) if len(claims) else "<p>no drop runs</p>",
            claims.to_html(index=False) if len(claims) else "",
            "<h2>Pre-impact strategies (none vs reshape, none vs direction)</h2>"]
    for title, table in pre_tables.items():
        body += [f"<h3>{html.escape(title)}</h3>", table.to_html(index=False) if len(table) else "<p>no runs</p>"]
    body += [_img(p) for p in pre_paths if p.suffix == ".png"]
    if len(sensitivity):
        body += ["<h2>Sensitivity to the baseline stiffness</h2>", sensitivity.round(3).to_html(index=False)]
        body += [_img(p) for p in sensitivity_paths if p.suffix == ".png"]
    body += ["<h2>Medians per scenario, strategy and policy</h2>", medians.round(3).to_html(),
            "<h2>Sweep comparisons</h2>"] + [_img(p) for p in sweep_paths if p.suffix == ".png"]
    for point, paths in figures.items():
        body += [f"<h2>{html.escape(point)}</h2>"] + [_img(p) for p in paths if p.suffix == ".png"]
    if len(failed):
        body += ["<h2>Failed runs</h2>", failed.to_html(index=False)]
    page = ("<!doctype html><html><head><meta charset='utf-8'><title>fallbench report</title>"
            "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
            "td,th{border:1px solid #ccc;padding:3px 6px;font-size:13px}</style></head><body>"
            + "\n".join(body) + "</body></html>")
    (out / "index.html").write_text(page)
    return [out / "index.html", out / "summary.md"] + [p for paths in figures.values() for p in paths] + sweep_paths + pre_paths + sensitivity_paths
