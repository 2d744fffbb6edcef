"""One page per robot and scenario family: verdict, forest plot, ranking, medians, sweeps, the
representative falls and the papers' figures per point."""

from __future__ import annotations

import html
from pathlib import Path

import fallbench.report.pages as pages
from fallbench.report.drawing import Drawn, Figure
from fallbench.report.family import Family
from fallbench.report.filmstrips import figure_name
from fallbench.report.forest import forest_table
from fallbench.report.grouping import unsettled_note
from fallbench.report.names import PAPERS, arm_name
from fallbench.report.sections import Sections

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


def forest_images(paths: list[Path], out: Path) -> list[str]:
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
        *forest_images(drawn.paths.get(f"forest:{family.stem}", []), out),
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


def write_family_pages(out: Path, sections: Sections) -> list[Path]:
    """One page per robot and scenario family."""
    return [
        _family_page(family, out, sections.drawn, sections.paper[family.stem]) for family in sections.families
    ]
