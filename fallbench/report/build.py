"""`fallbench report`'s orchestration: load and select the runs, hand every figure to the drawing
workers, compute the tables while they draw, then write the pages (family_page.py, index_page.py,
summary_page.py)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

import fallbench.report.pages as pages
import fallbench.report.ranking as ranking
from fallbench.report.detection import detection_job, detection_section
from fallbench.report.drawing import Drawing, Figure, start_workers
from fallbench.report.family import Family, find_families
from fallbench.report.family_page import write_family_pages
from fallbench.report.figure_files import files_only
from fallbench.report.figure_jobs import (
    direction_job,
    forest_jobs,
    per_family_paper_jobs,
    summary_figure_jobs,
)
from fallbench.report.filmstrips import filmstrip_figures
from fallbench.report.forest import Pool, pools
from fallbench.report.grouping import newest_runs, settled_runs, with_robot
from fallbench.report.index_page import index_answer, index_evidence, index_links
from fallbench.report.papers.claims import claims_table, robust_claims, verdict_matrix
from fallbench.report.papers.reshape import (
    preimpact_tables,
)
from fallbench.report.sections import Options, Sections
from fallbench.report.selection import among_objects
from fallbench.report.sensitivity import SWEEPS, sensitivity_runs, sensitivity_table
from fallbench.report.summary_page import summary_answer, summary_files, summary_tables
from fallbench.report.sweeps import median_table
from fallbench.report.validity import split_steps, step_changes
from fallbench.results import store


def draw_sections(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, options: Options
) -> Sections:
    """Draw every figure into `out` (in parallel, the unchanged ones from the cache) and compute
    every table of the report; `halved` are the runs at another physics step, for the
    numerical-validity section only."""
    drawing = Drawing(results, out, options.jobs, options.svg)
    summary = summary_figure_jobs(runs, out) + direction_job(runs, results, out) + detection_job(runs, out)
    drawing.add(sorted(summary, key=_slowest_first))  # drawn while the families are ranked
    per_robot = ranking.robots(runs)
    families = find_families(per_robot, options.filmstrips, options.unsettled)
    figures, paper, pooled = _start_figures(drawing, runs, per_robot, families, results, out, options)
    figures += summary
    tables = _tables(runs, halved, families)  # while the workers draw
    drawn = drawing.finish(figures)
    options.drawn, options.cached = drawn.drawn, drawn.cached

    def paths(prefix: str) -> list[Path]:
        return [p for name, ps in drawn.paths.items() if name.startswith(prefix) for p in ps]

    direction_paths, direction_tables = paths("004:report"), drawn.payloads.get("004:report", {})
    return Sections(
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
    """Hand every figure of the families to `drawing` as soon as its inputs are known, those that
    take longest first, so that the workers finish together; returns them in the report's order
    (the summary's figures, added before, follow them), each family's per-point figures and the
    pools of families of the forest plots."""
    objects = frozenset(runs.run_id[among_objects(runs)])
    strips = filmstrip_figures([p for f in families for p in f.picks], results, out, objects)
    drawing.add(strips)  # in groups of a scene, each a few seconds
    paper = per_family_paper_jobs(families, results, out, options.paper_figures)
    paper_jobs = [job for family_jobs in paper.values() for job in family_jobs]
    drawing.add(sorted(paper_jobs, key=_slowest_first))
    pooled = {robot: pools(robot_runs) for robot, robot_runs in per_robot.items()}
    forest = forest_jobs(pooled, families, out)
    drawing.add(forest)
    return strips + forest + paper_jobs, paper, pooled


# CPU seconds a figure of each kind took on the main job's report (its .figure-cache.json): only
# the order the workers take the figures in follows from them
TYPICAL_CPU_S = {
    **{"004": 1.3, "sweeps": 1.0, "002": 0.9, "detection": 0.9, "reshape": 0.5},
    **{"preimpact": 0.4, "filmstrip": 0.3, "forest": 0.3},
}


def _slowest_first(figure: Figure) -> float:
    return -TYPICAL_CPU_S.get(figure.name.split(":")[0], 0.2)


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


DRAWING_MODULES = ("fallbench.report.filmstrips", "fallbench.report.forest", "fallbench.report.sweeps")


def build_report(
    results: Path, out: Path, progress: bool = True, options: Options | None = None
) -> list[Path]:
    """Write the report of the store `results` into `out`: figures, index.html, one page per robot
    and scenario family, summary.md. Returns the files written, index.html and summary.md first.
    Figures are drawn on `options.jobs` processes; those whose runs and code did not change since
    the last report into `out` are kept (drawing.py)."""
    files_only()  # with one job, the figures are drawn in this process
    options = options or Options()
    start_workers(options.jobs, DRAWING_MODULES)
    runs = store.load_metrics(results)
    if runs.empty:
        raise FileNotFoundError(f"{results}: the results store has no runs")
    runs, options.set_aside = newest_runs(with_robot(runs), results)  # one run per fall, the newest
    runs, options.unsettled = settled_runs(runs)
    runs, halved = split_steps(runs)
    out.mkdir(parents=True, exist_ok=True)
    sections = draw_sections(runs, halved, results, out, options)
    per_robot = ranking.robots(runs)
    family_pages = write_family_pages(out, sections)
    detection = detection_section(runs, out, sections.drawn)  # fall detection judged on the none + stiff runs
    if detection is not None:
        family_pages.append(detection)

    index_body = index_answer(runs, halved, results, out, sections)
    index_body += index_evidence(per_robot, out, sections) + index_links(family_pages, sections)
    index = pages.write(out / "index.html", "fallbench report", index_body)

    summary = summary_answer(runs, halved, results, out, sections)
    summary += summary_tables(sections) + summary_files(family_pages, sections)
    (out / "summary.md").write_text("\n".join(summary) + "\n")
    files = [index, out / "summary.md", *family_pages]
    return files + list(dict.fromkeys(p for paths in sections.drawn.paths.values() for p in paths))
