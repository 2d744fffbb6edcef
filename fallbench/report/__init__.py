"""`fallbench report`: the answer first (rankings with intervals per robot and family), rendered falls,
the papers' figures and claims; index.html, one page per family, and summary.md."""

from __future__ import annotations

import html
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from fallbench.report import pages, ranking
from fallbench.report.detection import detection_section
from fallbench.report.drawing import Drawing, Drawn, Figure
from fallbench.report.filmstrips import Pick, family_picks, figure_name, filmstrip_figures
from fallbench.report.forest import Pool, forest_figure, forest_markdown, forest_table, paired_changes, pools
from fallbench.report.grouping import newest_runs, settled_runs, unsettled_note, with_robot
from fallbench.report.names import PAPERS, arm_name
from fallbench.report.paired import REFERENCE
from fallbench.report.papers.claims import claims_table, robust_claims, verdict_matrix
from fallbench.report.papers.direction import direction_report, top_down_figure
from fallbench.report.papers.drop_figures import draw_paper_figures, paper_points
from fallbench.report.papers.figures_004 import mirrors
from fallbench.report.papers.reshape import (
    draw_reshaped_falls,
    first_impact_figure,
    preimpact_tables,
    reshape_points,
)
from fallbench.report.sensitivity import SWEEPS, sensitivity_figure, sensitivity_runs, sensitivity_table
from fallbench.report.sweeps import KEY_METRICS, distribution_figure, median_table, parameter_figures
from fallbench.report.validity import split_steps, step_changes
from fallbench.results import store


@dataclass
class Family:
    """One robot's scenario family: its runs, ranking (computed once) and representative falls."""

    robot: str
    name: str
    runs: pd.DataFrame
    ranked: ranking.Ranked
    picks: list[Pick]  # the falls shown as filmstrips (`--filmstrips`)
    changes: pd.DataFrame  # paired changes against none + stiff (the forest plot's numbers)
    arm_picks: list[Pick]  # the typical and worst fall of every (strategy, policy)
    unsettled: int = 0  # runs that did not settle by their cap, left out of `runs`
    medians: pd.DataFrame | None = None  # sweeps.median_table, set by `_tables`

    @property
    def table(self) -> pd.DataFrame:
        return ranking.shown_table(self.ranked)

    @property
    def verdict(self) -> str:
        return ranking.verdict(self.runs, self.ranked)

    @property
    def title(self) -> str:
        return f"{self.robot} {self.name}".strip()

    @property
    def stem(self) -> str:
        return pages.family_file(self.robot, self.name).removesuffix(".html")


def _families(
    per_robot: dict[str, pd.DataFrame], filmstrips: str = "family", unsettled: pd.DataFrame | None = None
) -> list[Family]:
    left_out = Counter(zip(unsettled.robot, unsettled.scenario)) if unsettled is not None else Counter()
    found = []
    for robot, robot_runs in per_robot.items():
        for family in ranking.families(robot_runs):
            group = robot_runs[robot_runs.scenario == family]
            done = ranking.ranked(group)
            arms = ranking.arm_order(group, done)
            every_arm = family_picks(robot, family, group, arms, "all")
            shown = every_arm if filmstrips == "all" else family_picks(robot, family, group, arms, filmstrips)
            changes = paired_changes(group, done)
            found.append(
                Family(robot, family, group, done, shown, changes, every_arm, left_out[(robot, family)])
            )
    return found


PAPERS_NOTE = "The papers, by number: " + "; ".join(PAPERS.values()) + "."
PAPER_FIGURES = ("chosen", "all")  # `fallbench report --paper-figures`


def _paper_rows(family: Family, results: Path, which: str) -> list[tuple[str, pd.DataFrame]]:
    """The points of a family that get 002's figures, as (point, its runs): with "all" every
    eligible point (`figures.paper_points`; runs stored with their time series); with "chosen" one:
    the point of its worst shown fall if eligible, else of its other shown falls in order, else
    its first eligible point."""
    eligible = paper_points(store.with_timeseries(results, family.runs))  # not --timeseries none
    if which == "all" or not eligible:
        return eligible
    by_point = dict(eligible)
    shown = sorted(family.picks, key=lambda p: p.role != "worst")  # the worst first, then in order
    point = next((p.point for p in shown if p.point in by_point), eligible[0][0])
    return [(point, by_point[point])]


def _paper_jobs(
    families: list[Family], results: Path, out: Path, which: str = "chosen"
) -> dict[str, list[Figure]]:
    """Family stem -> the figures of 002 per point (`_paper_rows`), 004's top-down plots (`none`
    and `direction` on the same point and policy, with a control origin) and the reshaped falls
    (each family's typical `reshape` fall, `preimpact.reshape_points`)."""
    jobs: dict[str, list[Figure]] = {}
    for family in families:
        mine = [
            Figure(
                f"002:{family.robot}:{point}",
                draw_paper_figures,
                (_slim(rows), results, out, point),
                tuple(rows.run_id),
            )
            for point, rows in _paper_rows(family, results, which)
        ]
        mine += _top_down_jobs(family, results, out)
        mine += [
            Figure(
                f"reshape:{family.robot}:{point}:{policy}",
                draw_reshaped_falls,
                (rows, results, out, point, policy),
                tuple(rows.run_id),
            )
            for point, policy in reshape_points([p for p in family.arm_picks if p.role == "typical"])
            for rows in [_one_run_each(family, point, policy)]
        ]
        jobs[family.stem] = mine
    return jobs


def _top_down_jobs(family: Family, results: Path, out: Path) -> list[Figure]:
    """004's top-down plots of the family's chosen `direction` falls (the mirrors of 004's figures
    get theirs from `direction_report`)."""
    if family.name in mirrors(family.runs, results):
        return []
    jobs = []
    for pick in family.picks:
        if pick.pre_impact != "direction":
            continue
        rows = _one_run_each(family, pick.point, pick.policy, pick.run_id)
        if {"none", "direction"} <= set(rows.pre_impact) and "direction_origin_x" in rows:
            jobs.append(
                Figure(
                    f"004:{family.robot}:{pick.point}:{pick.policy}",
                    top_down_figure,
                    (rows, results, out, pick.point, pick.policy),
                    tuple(rows.run_id),
                )
            )
    return list({job.name: job for job in jobs}.values())


def _one_run_each(family: Family, point: str, policy: str, chosen: str = "") -> pd.DataFrame:
    """The point's successful runs under `policy`, one per strategy: the chosen run for its own
    strategy, else the smallest run id (a store may hold the same point twice, e.g. run by two
    versions of fallbench)."""
    rows = family.runs[
        (family.runs.point == point) & (family.runs.policy == policy) & (family.runs.status == "ok")
    ]
    rows = rows.assign(first=rows.run_id != chosen).sort_values(["first", "run_id"])
    return rows.drop_duplicates("pre_impact").drop(columns="first").sort_values("run_id")


def _slim(rows: pd.DataFrame) -> pd.DataFrame:
    """The columns the figures of 002 read: fewer cells to hash and to send to a worker."""
    return rows[[c for c in ("run_id", "robot", "point", "policy", "impact_time") if c in rows]]


def _forest_jobs(pooled: dict[str, list[Pool]], families: list[Family], out: Path) -> list[Figure]:
    """The overview's forest plots per robot (one per pool of families with the same arms) and one
    per family."""
    jobs = []
    for robot, robot_pools in pooled.items():
        total = sum(f.robot == robot for f in families)
        for k, pool in enumerate(robot_pools):
            title = f"Change against none + stiff on the same point and seed; {pool.title(robot, total)}"
            stem = f"forest_{robot or 'all'}" + (f"_{k + 1}" if k else "")
            jobs.append(Figure(f"forest:{robot}:{k}", forest_figure, (pool.changes, title, out, stem)))
    for family in families:
        title = f"{family.title}: change against none + stiff on the same point and seed"
        jobs.append(
            Figure(
                f"forest:{family.stem}", forest_figure, (family.changes, title, out, f"forest_{family.stem}")
            )
        )
    return jobs


def _summary_figure_jobs(runs: pd.DataFrame, out: Path) -> list[Figure]:
    """Figures of metric rows only: distributions, metrics vs swept values, first impacts, sensitivity."""
    ok = runs[runs.status == "ok"]
    jobs = [Figure("sweeps:distributions", distribution_figure, (ok[["policy", *KEY_METRICS]], out))]
    keep = ["robot", "scenario", "pre_impact", "policy", *KEY_METRICS]
    for (robot, family), group in ok.groupby(["robot", "scenario"]):
        params = [c for c in group.columns if c.startswith("param:") and group[c].notna().any()]
        if params:
            jobs.append(Figure(f"sweeps:{robot}:{family}", parameter_figures, (group[keep + params], out)))
    if "first_impact_group" in runs:
        jobs.append(Figure("preimpact:first_impact", first_impact_figure, (runs, out)))
    for sweep in SWEEPS:
        swept = sensitivity_runs(runs, sweep)
        if len(swept):
            jobs.append(Figure(f"sensitivity:{sweep.name}", sensitivity_figure, (swept, out, sweep)))
    return jobs


def _direction_job(runs: pd.DataFrame, results: Path, out: Path) -> list[Figure]:
    """004's report (`direction_report`: figures and tables) as one job, on the families with
    `direction` runs."""
    families = runs.loc[runs.pre_impact == "direction", "scenario"].unique()
    mine = runs[runs.scenario.isin(families)]
    if mine.empty:
        return []
    return [Figure("004:report", direction_report, (mine, results, out), tuple(mine.run_id))]


def _answer(families: list[Family], robot: str) -> list[str]:
    """Per scenario family: the one-line verdict and the ranking with intervals, linked to its page."""
    body = []
    for family in (f for f in families if f.robot == robot):
        body += [
            f"<h3>{pages.link(pages.family_file(robot, family.name), family.name)} "
            f"<small>({family.runs.point.nunique()} points x seeds, {len(family.runs)} runs)</small></h3>",
            f"<p class='verdict'>{html.escape(family.verdict)}</p>",
            pages.table(family.table),
        ]
    return body


FOREST_NOTE = (
    "Each row a pre-impact strategy + gain policy, best mean rank first; each panel a damage measure. "
    "Dot: the median of its paired changes against the unprotected fall (none + stiff) of the same point "
    "and seed (fell and counts: the mean, e.g. the change in the fraction of runs that fell); bar: 95 % bootstrap "
    "interval; grey line: no change. A bar clear of the line is a change the data support. Last panel: "
    "the probability of improvement, the share of pairs in which the arm does less damage (each pair "
    "scored 1, 0.5 or 0 per measure, averaged over the measures; grey line at 0.5). Marker: "
    "circle none, square reshape, diamond direction, triangle any other (e.g. a whole-fall controller such "
    "as onnx, policy -); colour: the gain policy; n: pairs."
)


def _forest(paths: list[Path], out: Path) -> list[str]:
    if not paths:
        return ["<p>(no forest plot: no none + stiff runs to pair with)</p>"]
    return [pages.image(p, out) for p in paths if p.suffix == ".png"] + [
        f"<p><small>{FOREST_NOTE}</small></p>"
    ]


def _picked_strips(family: Family, drawn: Drawn, out: Path) -> list[str]:
    """The family's representative falls (`Family.picks`, see DAMAGE_NOTE)."""
    body = []
    for pick in family.picks:
        paths = drawn.paths.get(figure_name(pick.run_id), [])
        caption = f"{arm_name(pick.pre_impact, pick.policy)}, {pick.role} fall (damage {pick.damage:.2f}): {pick.point}"
        note = drawn.notes.get(figure_name(pick.run_id), "")
        body.append(f"<h4>{html.escape(caption)}</h4>")
        body += [pages.image(p, out) for p in paths] or [f"<p><em>{html.escape(note)}</em></p>"]
    return body


def _family_page(family: Family, out: Path, drawn: Drawn, paper: list[Figure]) -> Path:
    group = family.runs
    body = [
        f"<p>{pages.link('index.html', 'overview')}</p>",
        f"<h1>{html.escape(family.title)}</h1>",
        f"<p>{len(group)} runs over {group.point.nunique()} points (sweep values x seeds)"
        f"{'; ' + unsettled_note(family.unsettled) if family.unsettled else ''}.</p>",
        f"<p class='verdict'>{html.escape(family.verdict)}</p>",
        "<h2>Change against the unprotected fall (none + stiff), per damage measure</h2>",
        *_forest(drawn.paths.get(f"forest:{family.stem}", []), out),
        "<h2>Ranking: median [95 % bootstrap CI] over points and seeds, best mean rank first</h2>",
        pages.table(family.table),
        "<h2>Change against the unprotected fall (none + stiff) of the same point and seed: the forest "
        "plot's numbers</h2>",
        pages.table(forest_table(family.changes)),
        "<h2>Medians per strategy and policy</h2>",
        pages.table(family.medians.round(3), index=True),
    ]
    mine = [p for p in drawn.paths.get(f"sweeps:{family.robot}:{family.name}", []) if p.suffix == ".png"]
    if mine:
        body += ["<h2>Metrics against the swept values</h2>"] + [pages.image(p, out) for p in mine]
    if family.picks:
        body += [
            "<h2>Representative falls</h2>",
            f"<p><small>{html.escape(DAMAGE_NOTE)}</small></p>",
            *_picked_strips(family, drawn, out),
        ]
    figures = [(job, drawn.paths.get(job.name, [])) for job in paper]
    figures = [(job, [p for p in paths if p.suffix == ".png"]) for job, paths in figures]
    if any(paths for _, paths in figures):
        body.append(
            f"<h2>Per point: the figures of {PAPERS['002']} (IMU z, right knee, leg torques, adaptive "
            f"gains), the top-down view of {PAPERS['004']}, reshaped falls</h2>"
        )
    for job, paths in figures:
        if paths:
            images = "".join(pages.image(p, out) for p in paths)
            body.append(
                f"<details><summary>{html.escape(job.name.split(':', 2)[-1])}</summary>{images}</details>"
            )
    body += [
        f"<p><em>{html.escape(drawn.notes[job.name])}</em></p>" for job in paper if job.name in drawn.notes
    ]
    return pages.write(out / pages.family_file(family.robot, family.name), family.title, body)


DAMAGE_NOTE = (
    "Chosen by the data: a run's damage is the mean, over the damage measures of the ranking, of its "
    "percentile rank among the family's runs (1 = the most damage on every measure). A typical fall "
    "is the run of damage nearest its strategy and policy's median. Shown by default: the typical fall "
    "of the best strategy and policy and of none + stiff, and the family's worst fall; with "
    "`fallbench report --filmstrips all`: per strategy and policy its typical and its worst fall."
)


@dataclass
class _Sections:
    """Everything the overview and summary.md show, computed once: figure paths and tables."""

    families: list[Family]
    drawn: Drawn
    paper: dict[str, list[Figure]]  # family stem -> its per-point figure jobs
    sweep_paths: list[Path]
    pre_paths: list[Path]  # pre-impact strategies: reshape, then direction
    pre_tables: dict[str, pd.DataFrame]
    sensitivity_paths: list[Path]
    sensitivity: dict[str, pd.DataFrame]  # "the baseline stiffness" -> medians per setting
    medians: pd.DataFrame
    claims: pd.DataFrame
    verdicts: pd.DataFrame
    step_changes: pd.DataFrame  # headline metrics' change when the physics step is halved
    failed: pd.DataFrame
    pooled: dict[str, list[Pool]]  # robot -> its families pooled by the arms that ran in them
    set_aside: int = 0  # older duplicates of a fall left out (grouping.newest_runs)
    unsettled: int = 0  # runs that did not settle by their cap, left out (grouping.settled_runs)

    @property
    def strip_paths(self) -> list[Path]:
        return [p for name, paths in self.drawn.paths.items() if name.startswith("filmstrip:") for p in paths]

    @property
    def figure_paths(self) -> list[Path]:
        return [p for jobs in self.paper.values() for job in jobs for p in self.drawn.paths.get(job.name, [])]

    def forest(self, robot: str) -> list[Path]:
        return [
            p for k in range(len(self.pooled[robot])) for p in self.drawn.paths.get(f"forest:{robot}:{k}", [])
        ]

    @property
    def strip_note(self) -> str:
        notes = {n for name, n in self.drawn.notes.items() if name.startswith("filmstrip:")}
        return "; ".join(sorted(notes))


def _sections(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, options: Options
) -> _Sections:
    """Draw every figure into `out` (in parallel, the unchanged ones from the cache) and compute
    every table of the report; `halved` are the runs at another physics step, for the
    numerical-validity section only."""
    per_robot = ranking.robots(runs)
    families = _families(per_robot, options.filmstrips, options.unsettled)
    drawing = Drawing(results, out, options.jobs, options.svg)
    figures, paper, pooled = _start_figures(drawing, runs, per_robot, families, results, out, options)
    tables = _tables(runs, halved, families)  # while the workers draw
    drawn = drawing.finish(figures)
    options.drawn, options.cached = drawn.drawn, drawn.cached

    def paths(prefix: str) -> list[Path]:
        return [p for name, ps in drawn.paths.items() if name.startswith(prefix) for p in ps]

    direction_paths, direction_tables = paths("004:report"), drawn.payloads.get("004:report", {})
    return _Sections(
        families=families,
        drawn=drawn,
        paper=paper,
        sweep_paths=paths("sweeps:"),
        pre_paths=paths("preimpact:") + paths("reshape:") + direction_paths,
        pre_tables=tables.pop("pre_tables") | direction_tables,
        sensitivity_paths=paths("sensitivity:"),
        failed=runs[runs.status != "ok"][["point", "policy", "pre_impact", "status", "error"]],
        pooled=pooled,
        set_aside=options.set_aside,
        unsettled=len(options.unsettled) if options.unsettled is not None else 0,
        **tables,
    )


def _start_figures(
    drawing: Drawing,
    runs: pd.DataFrame,
    per_robot: dict[str, pd.DataFrame],
    families: list[Family],
    results: Path,
    out: Path,
    options: Options,
) -> tuple[list[Figure], dict[str, list[Figure]], dict[str, list[Pool]]]:
    """Hand every figure to `drawing` as soon as its inputs are known; returns them in the report's
    order, each family's per-point figures and the pools of families of the forest plots."""
    strips = filmstrip_figures([p for f in families for p in f.picks], results, out)
    # filmstrips first: a worker's first figure sets the memory baseline loky restarts it above
    # (300 MB), and the renderer's libraries would otherwise count as a leak; then the figures
    # that take longest, so that the workers finish together
    drawing.add(strips[: options.jobs])
    summary = _summary_figure_jobs(runs, out) + _direction_job(runs, results, out)
    drawing.add(summary)
    paper = _paper_jobs(families, results, out, options.paper_figures)
    paper_jobs = [job for family_jobs in paper.values() for job in family_jobs]
    drawing.add(paper_jobs)
    pooled = {robot: pools(robot_runs) for robot, robot_runs in per_robot.items()}
    forest = _forest_jobs(pooled, families, out)
    drawing.add(forest + strips[options.jobs :])
    return strips + forest + paper_jobs + summary, paper, pooled


def _tables(runs: pd.DataFrame, halved: pd.DataFrame, families: list[Family]) -> dict:
    """Every table of the report that reads metric rows only (computed while the figures are drawn)."""
    claims = robust_claims(claims_table(runs), halved)
    for family in families:  # computed once, here, for their pages
        family.medians = median_table(family.runs)
    return {
        "sensitivity": {
            sweep.title: sensitivity_table(swept, sweep)
            for sweep in SWEEPS
            for swept in [sensitivity_runs(runs, sweep)]
            if len(swept)
        },
        "pre_tables": preimpact_tables(runs),
        "medians": median_table(runs),
        "claims": claims,
        "verdicts": verdict_matrix(claims),
        "step_changes": step_changes(runs, halved) if len(halved) else pd.DataFrame(),
    }


def _family_pages(out: Path, sections: _Sections) -> list[Path]:
    """One page per robot and scenario family."""
    return [
        _family_page(family, out, sections.drawn, sections.paper[family.stem]) for family in sections.families
    ]


def _counted(runs: pd.DataFrame, halved: pd.DataFrame, set_aside: int = 0, unsettled: int = 0) -> str:
    """ "N runs", the runs at another physics step that only the numerical validity reads, and the
    older runs of a fall stored again that the report leaves out."""
    other = (
        f" (and {len(halved)} at another physics step, in the numerical validity only)" if len(halved) else ""
    )
    older = (
        f"; {set_aside} older run(s) of a fall stored again set aside (the newest run of each "
        "robot, scenario, point, seed, physics step, strategy and policy is used)"
        if set_aside
        else ""
    )
    resting = f"; {unsettled_note(unsettled)}" if unsettled else ""
    return f"{len(runs)} runs{other}{older}{resting}"


def _index_answer(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, sections: _Sections
) -> list[str]:
    """The overview's opening: what was run, the forest plot per robot, then per robot the ranking
    of every family."""
    body = [
        f"<h1>fallbench report</h1><p>{_counted(runs, halved, sections.set_aside, sections.unsettled)} from <code>{html.escape(str(results))}</code>; "
        f"{len(sections.failed)} failed or diverged. Every interval is a 95 % percentile bootstrap (seeded) over the "
        f"runs of a family: its sweep points and seeds. {html.escape(PAPERS_NOTE)}</p>",
        "<h2>What hurts the robot least</h2>",
    ]
    robots = list(dict.fromkeys(f.robot for f in sections.families))
    for robot in robots:
        body += [
            f"<h3>Change against the unprotected fall, {html.escape(robot)}: families pooled where the "
            "same arms ran</h3>",
            *_forest(sections.forest(robot), out),
        ]
    body.append(f"<p class='verdict'>{html.escape(_headline_count(sections.families))}</p>")
    body.append(
        "<p>Per scenario family, each (pre-impact strategy, gain policy) on the damage measures: median "
        "[95 % CI] (fell: fraction of runs), ordered by the mean of its ranks over the measures (1 = least damage on all).</p>"
    )
    for robot in robots:
        if robot:
            body.append(f"<h2>Robot {html.escape(robot)}</h2>")
        body += _answer(sections.families, robot)
    return body


def _headline_count(families: list[Family]) -> str:
    """How often doing nothing wins, per robot: the families (of more than one arm) whose verdict
    names none + stiff, and the ties."""
    parts = []
    for robot in dict.fromkeys(f.robot for f in families):
        contested = [f for f in families if f.robot == robot and len(f.ranked.table) > 1]
        unprotected = ties = 0
        for family in contested:
            arms = ranking.best_arms(family.ranked)
            ties += len(arms) > 1
            unprotected += len(arms) == 1 and REFERENCE in [arms[0], *family.ranked.same[arms[0]]]
        parts.append(f"{robot} {unprotected} of {len(contested)} (ties: {ties})".strip())
    return (
        "Families whose verdict names the unprotected fall (none + stiff) least damage: "
        + "; ".join(parts)
        + "."
    )


def _index_evidence(per_robot: dict[str, pd.DataFrame], out: Path, sections: _Sections) -> list[str]:
    """The overview after the answer: falls, claims, changes, pre-impact strategies, sensitivity."""
    body = [
        "<h2>Falls, rendered</h2>",
        "<p>Each family's page shows representative falls chosen by their damage as filmstrips "
        f"({len(sections.strip_paths)} rendered): {html.escape(DAMAGE_NOTE)}</p>",
    ]
    if sections.strip_note:
        body.append(f"<p><em>{html.escape(sections.strip_note)}</em></p>")
    body += ["<h2>Claims of the papers</h2>", pages.table(sections.verdicts), pages.table(sections.claims)]
    if len(sections.step_changes):
        body += [
            "<h2>Numerical validity</h2>",
            "<p>The same falls at half the physics step: each headline measure's change (the rankings use "
            "the default step only). A claim is robust only if its verdict is the same at both steps "
            "(the claims table's last columns).</p>",
            pages.table(sections.step_changes),
        ]
    for robot, robot_pools in sections.pooled.items():
        total = sum(f.robot == robot for f in sections.families)
        for pool in robot_pools:
            body += [
                f"<h2>Change against the unprotected fall (none + stiff): {html.escape(pool.title(robot, total))}</h2>",
                pages.table(forest_table(pool.changes)),
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
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, sections: _Sections
) -> list[str]:
    """summary.md's opening: what was run, the forest plots, then the verdict and ranking of every
    robot and family."""
    summary = [
        "# fallbench report",
        "",
        f"{_counted(runs, halved, sections.set_aside, sections.unsettled)} from `{results}`; {len(sections.failed)} failed or diverged. "
        + PAPERS_NOTE,
        "",
        "## What hurts the robot least",
        "",
        FOREST_NOTE,
        "",
    ]
    for robot in dict.fromkeys(f.robot for f in sections.families):
        summary += [
            f"![{robot} forest plot]({p.relative_to(out)})"
            for p in sections.forest(robot)
            if p.suffix == ".png"
        ]
        summary.append("")
    summary += ["(median [95 % bootstrap CI] over points and seeds)", ""]
    for family in sections.families:
        summary += [
            f"### {family.title}",
            "",
            family.verdict,
            "",
            forest_markdown(family.changes) or "(no none + stiff runs to pair with)",
            "",
            family.table.to_markdown(index=False),
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


@dataclass
class Options:
    """How to draw: worker processes, vector files; and what happened (figures drawn, cached)."""

    jobs: int = 1
    svg: bool = False
    filmstrips: str = "family"  # `filmstrips.SCOPES`: three falls per family, or two per strategy and policy
    paper_figures: str = "chosen"  # PAPER_FIGURES: one point per family, or every eligible point
    drawn: int = 0
    cached: int = 0
    set_aside: int = 0  # older runs of a fall stored again (grouping.newest_runs), left out
    unsettled: pd.DataFrame | None = None  # runs that did not settle by their cap (grouping.settled_runs)


def build_report(
    results: Path, out: Path, progress: bool = True, options: Options | None = None
) -> list[Path]:
    """Write the report of the store `results` into `out`: figures, index.html, one page per robot
    and scenario family, summary.md. Returns the files written, index.html and summary.md first.
    Figures are drawn on `options.jobs` processes; those whose runs and code did not change since
    the last report into `out` are kept (drawing.py)."""
    options = options or Options()
    runs = store.load_metrics(results)
    if runs.empty:
        raise FileNotFoundError(f"{results}: the results store has no runs")
    runs, options.set_aside = newest_runs(with_robot(runs), results)  # one run per fall, the newest
    runs, options.unsettled = settled_runs(runs)
    runs, halved = split_steps(runs)
    out.mkdir(parents=True, exist_ok=True)
    sections = _sections(runs, halved, results, out, options)
    per_robot = ranking.robots(runs)
    family_pages = _family_pages(out, sections)
    detection = detection_section(runs, out)  # fall detection judged on the none + stiff runs
    if detection is not None:
        family_pages.append(detection)

    index_body = _index_answer(runs, halved, results, out, sections)
    index_body += _index_evidence(per_robot, out, sections) + _index_links(family_pages, sections)
    index = pages.write(out / "index.html", "fallbench report", index_body)

    summary = _summary_answer(runs, halved, results, out, sections)
    summary += _summary_tables(sections) + _summary_files(family_pages, sections)
    (out / "summary.md").write_text("\n".join(summary) + "\n")
    files = [index, out / "summary.md", *family_pages]
    return files + list(dict.fromkeys(p for paths in sections.drawn.paths.values() for p in paths))
