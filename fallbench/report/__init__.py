"""`fallbench report`: the answer first (rankings with intervals per robot and family), rendered falls,
the papers' figures and claims; index.html, one page per family, and summary.md."""

from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from fallbench.report import pages, ranking
from fallbench.report.claims import claims_table, verdict_matrix
from fallbench.report.direction import direction_report
from fallbench.report.figures import gains_figure, imu_figure, knee_figure, torque_figure
from fallbench.report.filmstrips import render_filmstrips
from fallbench.report.grouping import with_robot
from fallbench.report.preimpact import preimpact_report
from fallbench.report.sensitivity import SWEEPS, sensitivity_figure, sensitivity_runs, sensitivity_table
from fallbench.report.stats import natural_sorted
from fallbench.report.sweeps import distribution_figure, median_table, parameter_figures
from fallbench.report.validity import robust_claims, split_steps, step_changes
from fallbench.results import store


def _leg(robot: str) -> tuple[dict[str, str], tuple[float, float], dict[str, float]]:
    """A robot's right-leg pitch joints, its knee range (rad, from the URDF) and their torque limits (Nm)."""
    from fallbench.scenario import Scenario
    from fallbench.sim.world import build_world

    world = build_world(Scenario(name="limits", duration=1.0, robot=robot))
    leg = world.robot.leg_pitch("right")
    low, high = world.joint_range[world.joint_names.index(leg["knee"])]
    return (
        leg,
        (float(low), float(high)),
        {j: float(world.torque_limit[world.joint_names.index(j)]) for j in leg.values()},
    )


def paper_figures(runs: pd.DataFrame, results: Path, out: Path, progress: bool) -> dict[str, list[Path]]:
    """Figs. 4, 5, 6a, 6b for each drop or push scenario point (seed 0) with more than one policy,
    as in 002: gain policies alone (pre-impact strategy `none`)."""
    figures: dict[str, list[Path]] = {}
    # seed 0 only: a randomised family gets one point's figures, not one per seed
    ok = runs[
        (runs.status == "ok")
        & runs.scenario.str.contains("drop|push")
        & (runs.pre_impact == "none")
        & (runs.seed == 0)
    ]
    ok = store.with_timeseries(results, ok)
    points = [(point, ok[ok.point == point]) for point in natural_sorted(ok.point.unique())]
    points = [(point, group) for point, group in points if group.policy.nunique() > 1]
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


def _answer(runs: pd.DataFrame, robot: str) -> list[str]:
    """Per scenario family: the one-line verdict and the ranking with intervals, linked to its page."""
    body = []
    for family in ranking.families(runs):
        group = runs[runs.scenario == family]
        body += [
            f"<h3>{pages.link(pages.family_file(robot, family), family)} "
            f"<small>({group.point.nunique()} points x seeds, {len(group)} runs)</small></h3>",
            f"<p class='verdict'>{html.escape(ranking.verdict(group))}</p>",
            pages.table(ranking.ranking_table(group)),
        ]
    return body


def _strip_images(strips: dict[str, list[Path]], out: Path, note: str) -> list[str]:
    body = [f"<p><em>{html.escape(note)}</em></p>"] if note else []
    for caption, paths in strips.items():
        body += [f"<h3>{html.escape(caption)}</h3>"] + [pages.image(p, out) for p in paths]
    return body


def _family_page(
    runs: pd.DataFrame,
    robot: str,
    family: str,
    out: Path,
    figures: dict[str, list[Path]],
    sweep_paths: list[Path],
    strips: dict[str, list[Path]],
) -> Path:
    group = runs[runs.scenario == family]
    title = f"{robot} {family}".strip()
    body = [
        f"<p>{pages.link('index.html', 'overview')}</p>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{len(group)} runs over {group.point.nunique()} points (sweep values x seeds).</p>",
        f"<p class='verdict'>{html.escape(ranking.verdict(group))}</p>",
        "<h2>Ranking: median [95 % bootstrap CI] over points and seeds, best mean rank first</h2>",
        pages.table(ranking.ranking_table(group)),
        "<h2>Change against the unprotected fall (none + stiff) of the same point and seed</h2>",
        pages.table(ranking.relative_changes(group)),
        "<h2>Medians per strategy and policy</h2>",
        pages.table(median_table(group).round(3), index=True),
    ]
    mine = [p for p in sweep_paths if p.suffix == ".png" and p.stem.startswith(f"sweep_{family}_")]
    if mine:
        body += ["<h2>Metrics against the swept values</h2>"] + [pages.image(p, out) for p in mine]
    strip_ids = set(group.run_id)
    chosen = {
        c: [p for p in paths if p.stem.removeprefix("filmstrip_") in strip_ids] for c, paths in strips.items()
    }
    body += _strip_images({c: paths for c, paths in chosen.items() if paths}, out, "")
    points = natural_sorted(p for p in figures if p in set(group.point))
    if points:
        body.append("<h2>Per point: the figures of 002 (IMU z, right knee, leg torques, adaptive gains)</h2>")
    for point in points:
        images = "".join(pages.image(p, out) for p in figures[point] if p.suffix == ".png")
        body.append(f"<details><summary>{html.escape(point)}</summary>{images}</details>")
    return pages.write(out / pages.family_file(robot, family), title, body)


@dataclass
class _Sections:
    """Everything the overview and summary.md show, computed once: figure paths and tables."""

    figures: dict[str, list[Path]]  # scenario point -> its figures of 002
    sweep_paths: list[Path]
    pre_paths: list[Path]  # pre-impact strategies: reshape, then direction
    pre_tables: dict[str, pd.DataFrame]
    sensitivity_paths: list[Path]
    sensitivity: dict[str, pd.DataFrame]  # "the baseline stiffness" -> medians per setting
    strips: dict[str, list[Path]]  # caption -> rendered filmstrips
    strip_note: str
    medians: pd.DataFrame
    claims: pd.DataFrame
    verdicts: pd.DataFrame
    step_changes: pd.DataFrame  # headline metrics' change when the physics step is halved
    failed: pd.DataFrame

    @property
    def strip_paths(self) -> list[Path]:
        return [p for paths in self.strips.values() for p in paths]

    @property
    def figure_paths(self) -> list[Path]:
        return [p for paths in self.figures.values() for p in paths]


def _sections(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, progress: bool
) -> _Sections:
    """Draw every figure into `out` and compute every table of the report; `halved` are the runs at
    another physics step, for the numerical-validity section only."""
    figures = paper_figures(runs, results, out, progress)
    ok = runs[runs.status == "ok"]
    sweep_paths = distribution_figure(ok, out) + parameter_figures(ok, out)
    pre_paths, pre_tables = preimpact_report(runs, results, out)
    sensitivity_paths, sensitivity = [], {}
    for sweep in SWEEPS:
        swept = sensitivity_runs(runs, sweep)
        sensitivity_paths += sensitivity_figure(swept, out, sweep)
        if len(swept):
            sensitivity[sweep.title] = sensitivity_table(swept, sweep)
    direction_paths, direction_tables = direction_report(runs, results, out)
    strips, strip_note = render_filmstrips(runs, results, out)
    medians = median_table(runs)
    claims = robust_claims(claims_table(runs), halved)
    return _Sections(
        figures=figures,
        sweep_paths=sweep_paths,
        pre_paths=pre_paths + direction_paths,
        pre_tables=pre_tables | direction_tables,
        sensitivity_paths=sensitivity_paths,
        sensitivity=sensitivity,
        strips=strips,
        strip_note=strip_note,
        medians=medians,
        claims=claims,
        verdicts=verdict_matrix(claims),
        step_changes=step_changes(runs, halved) if len(halved) else pd.DataFrame(),
        failed=runs[runs.status != "ok"][["point", "policy", "pre_impact", "status", "error"]],
    )


def _family_pages(per_robot: dict[str, pd.DataFrame], out: Path, sections: _Sections) -> list[Path]:
    """One page per robot and scenario family."""
    return [
        _family_page(robot_runs, robot, family, out, sections.figures, sections.sweep_paths, sections.strips)
        for robot, robot_runs in per_robot.items()
        for family in ranking.families(robot_runs)
    ]


def _counted(runs: pd.DataFrame, halved: pd.DataFrame) -> str:
    """ "N runs", and the runs at another physics step that only the numerical validity reads."""
    other = (
        f" (and {len(halved)} at another physics step, in the numerical validity only)" if len(halved) else ""
    )
    return f"{len(runs)} runs{other}"


def _index_answer(
    runs: pd.DataFrame,
    halved: pd.DataFrame,
    results: Path,
    per_robot: dict[str, pd.DataFrame],
    failed: pd.DataFrame,
) -> list[str]:
    """The overview's opening: what was run, then per robot the ranking of every family."""
    body = [
        f"<h1>fallbench report</h1><p>{_counted(runs, halved)} from <code>{html.escape(str(results))}</code>; "
        f"{len(failed)} failed or diverged. Every interval is a 95 % percentile bootstrap (seeded) over the "
        "runs of a family: its sweep points and seeds.</p>",
        "<h2>What hurts the robot least</h2>",
        "<p>Per scenario family, each (pre-impact strategy, gain policy) on the damage measures: median "
        "[95 % CI] (fell: fraction of runs), ordered by the mean of its ranks over the measures (1 = least damage on all).</p>",
    ]
    for robot, robot_runs in per_robot.items():
        if robot:
            body.append(f"<h2>Robot {html.escape(robot)}</h2>")
        body += _answer(robot_runs, robot)
    return body


def _index_evidence(per_robot: dict[str, pd.DataFrame], out: Path, sections: _Sections) -> list[str]:
    """The overview after the answer: falls, claims, changes, pre-impact strategies, sensitivity."""
    body = ["<h2>Falls, rendered</h2>"] + _strip_images(sections.strips, out, sections.strip_note)
    body += ["<h2>Claims of the papers</h2>", pages.table(sections.verdicts), pages.table(sections.claims)]
    if len(sections.step_changes):
        body += [
            "<h2>Numerical validity</h2>",
            "<p>The same falls at half the physics step: each headline measure's change (the rankings use "
            "the default step only). A claim is robust only if its verdict is the same at both steps "
            "(the claims table's last columns).</p>",
            pages.table(sections.step_changes),
        ]
    for robot, robot_runs in per_robot.items():
        body += [
            f"<h2>Change against the unprotected fall (none + stiff), all families {html.escape(robot)}</h2>",
            pages.table(ranking.relative_changes(robot_runs)),
        ]
    body.append("<h2>Pre-impact strategies (none vs reshape, none vs direction)</h2>")
    for title, frame in sections.pre_tables.items():
        body += [f"<h3>{html.escape(title)}</h3>", pages.table(frame)]
    body += [
        pages.image(p, out)
        for p in sections.pre_paths
        if p.suffix == ".png" and not p.stem.startswith("reshaped_fall_")
    ]
    for title, table in sections.sensitivity.items():
        stem = f"sensitivity_{table.columns[0]}"
        body += [f"<h2>Sensitivity to {title}</h2>", pages.table(table.round(3))]
        body += [
            pages.image(p, out) for p in sections.sensitivity_paths if p.suffix == ".png" and p.stem == stem
        ]
    return body


def _index_links(family_pages: list[Path], sections: _Sections) -> list[str]:
    """The overview's end: links to the family pages and figures, then the failed runs."""
    body = ["<h2>More</h2><ul>"] + [f"<li>{pages.link(p.name, p.stem)}</li>" for p in family_pages]
    body += [
        f"<li>{pages.link(p.name, p.stem)}</li>"
        for p in sections.sweep_paths + sections.pre_paths
        if p.suffix == ".png" and not p.stem.startswith("sweep_") or p.stem == "sweep_distributions"
    ] + ["</ul>"]
    if len(sections.failed):
        body += ["<h2>Failed runs</h2>", pages.table(sections.failed)]
    return body


def _summary_answer(
    runs: pd.DataFrame,
    halved: pd.DataFrame,
    results: Path,
    per_robot: dict[str, pd.DataFrame],
    failed: pd.DataFrame,
) -> list[str]:
    """summary.md's opening: what was run, then the verdict and ranking of every robot and family."""
    summary = [
        "# fallbench report",
        "",
        f"{_counted(runs, halved)} from `{results}`; {len(failed)} failed or diverged.",
        "",
        "## What hurts the robot least (median [95 % bootstrap CI] over points and seeds)",
        "",
    ]
    for robot, robot_runs in per_robot.items():
        for family in ranking.families(robot_runs):
            group = robot_runs[robot_runs.scenario == family]
            summary += [
                f"### {robot} {family}".replace("  ", " "),
                "",
                ranking.verdict(group),
                "",
                ranking.ranking_table(group).to_markdown(index=False),
                "",
            ]
    return summary


def _summary_tables(sections: _Sections) -> list[str]:
    """summary.md's tables: claims, pre-impact strategies, sensitivity, medians, failed runs."""
    claims, verdicts = sections.claims, sections.verdicts
    summary = [
        "## Claims",
        "",
        verdicts.to_markdown(index=False) if len(verdicts) else "",
        "",
        claims.to_markdown(index=False) if len(claims) else "(no drop runs)",
        "",
    ]
    if len(sections.step_changes):
        summary += [
            "## Numerical validity (the same falls at half the physics step)",
            "",
            sections.step_changes.to_markdown(index=False),
            "",
        ]
    summary += ["## Pre-impact strategies (none vs reshape, none vs direction)", ""]
    for title, frame in sections.pre_tables.items():
        summary += [f"### {title}", "", frame.to_markdown(index=False) if len(frame) else "(no runs)", ""]
    for title, table in sections.sensitivity.items():
        summary += [
            f"## Sensitivity to {title} (medians per {table.columns[0].replace('_', ' ')})",
            "",
            table.round(3).to_markdown(index=False),
            "",
        ]
    summary += [
        "## Medians per scenario, strategy and policy",
        "",
        sections.medians.round(3).to_markdown(),
        "",
    ]
    if len(sections.failed):
        summary += ["## Failed runs", "", sections.failed.to_markdown(index=False), ""]
    return summary


def _summary_files(family_pages: list[Path], sections: _Sections) -> list[str]:
    """summary.md's list of the pages and PNG figures written."""
    files = ["## Files", ""] + [f"- `{p.name}`" for p in family_pages + sections.strip_paths]
    files += [f"- `{p.name}`" for p in sections.figure_paths if p.suffix == ".png"]
    files += [
        f"- `{p.name}`"
        for p in sections.sweep_paths + sections.pre_paths + sections.sensitivity_paths
        if p.suffix == ".png"
    ]
    return files


def build_report(results: Path, out: Path, progress: bool = True) -> list[Path]:
    """Write the report of the store `results` into `out`: figures, index.html, one page per robot
    and scenario family, summary.md. Returns the files written, index.html and summary.md first."""
    runs = store.load_metrics(results)
    if runs.empty:
        raise FileNotFoundError(f"{results}: the results store has no runs")
    runs, halved = split_steps(with_robot(runs))
    out.mkdir(parents=True, exist_ok=True)
    sections = _sections(runs, halved, results, out, progress)
    per_robot = ranking.robots(runs)
    family_pages = _family_pages(per_robot, out, sections)

    index_body = _index_answer(runs, halved, results, per_robot, sections.failed)
    index_body += _index_evidence(per_robot, out, sections) + _index_links(family_pages, sections)
    index = pages.write(out / "index.html", "fallbench report", index_body)

    summary = _summary_answer(runs, halved, results, per_robot, sections.failed)
    summary += _summary_tables(sections) + _summary_files(family_pages, sections)
    (out / "summary.md").write_text("\n".join(summary) + "\n")
    return (
        [index, out / "summary.md"]
        + family_pages
        + sections.strip_paths
        + sections.figure_paths
        + sections.sweep_paths
        + sections.pre_paths
        + sections.sensitivity_paths
    )
