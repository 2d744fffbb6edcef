"""index.html: what was run, the forest plots and every family's ranking first, then the falls,
claims, numerical validity, pre-impact strategies and sensitivity, then links."""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

import fallbench.report.pages as pages
import fallbench.report.ranking as ranking
from fallbench.report.family import Family
from fallbench.report.family_page import DAMAGE_NOTE, forest_images
from fallbench.report.forest import forest_table
from fallbench.report.grouping import unsettled_note
from fallbench.report.names import PAPERS
from fallbench.report.paired import REFERENCE
from fallbench.report.sections import Sections

PAPERS_NOTE = "The papers, by number: " + "; ".join(PAPERS.values()) + "."


def counted(runs: pd.DataFrame, halved: pd.DataFrame, set_aside: int = 0, unsettled: int = 0) -> str:
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


def index_answer(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, sections: Sections
) -> list[str]:
    """The overview's opening: what was run, the forest plot per robot, then per robot the ranking
    of every family."""
    body = [
        f"<h1>fallbench report</h1><p>{counted(runs, halved, sections.set_aside, sections.unsettled)} from <code>{html.escape(str(results))}</code>; "
        f"{len(sections.failed)} failed or diverged. Every interval is a 95 % percentile bootstrap (seeded) over the "
        f"runs of a family: its sweep points and seeds. {html.escape(PAPERS_NOTE)}</p>",
        "<h2>What hurts the robot least</h2>",
    ]
    robots = list(dict.fromkeys(f.robot for f in sections.families))
    for robot in robots:
        body += [
            f"<h3>Change against the unprotected fall, {html.escape(robot)}: families pooled where the "
            "same arms ran</h3>",
            *forest_images(sections.forest(robot), out),
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


def index_evidence(per_robot: dict[str, pd.DataFrame], out: Path, sections: Sections) -> list[str]:
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


def index_links(family_pages: list[Path], sections: Sections) -> list[str]:
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
