"""summary.md: the overview in markdown: rankings, claims, pre-impact strategies, sensitivity,
medians, failed runs, and the files written."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from fallbench.report.family_page import FOREST_NOTE
from fallbench.report.forest import forest_markdown
from fallbench.report.index_page import PAPERS_NOTE, counted
from fallbench.report.sections import Sections


def summary_answer(
    runs: pd.DataFrame, halved: pd.DataFrame, results: Path, out: Path, sections: Sections
) -> list[str]:
    """summary.md's opening: what was run, the forest plots, then the verdict and ranking of every
    robot and family."""
    summary = [
        "# fallbench report",
        "",
        f"{counted(runs, halved, sections.set_aside, sections.unsettled)} from `{results}`; {len(sections.failed)} failed or diverged. "
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


def summary_tables(sections: Sections) -> list[str]:
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


def summary_files(family_pages: list[Path], sections: Sections) -> list[str]:
    """summary.md's list of the pages and PNG figures written."""
    files = ["## Files", ""] + [f"- `{p.name}`" for p in family_pages + sections.strip_paths]
    files += [f"- `{p.name}`" for p in sections.figure_paths if p.suffix == ".png"]
    files += [
        f"- `{p.name}`"
        for p in sections.sweep_paths + sections.pre_paths + sections.sensitivity_paths
        if p.suffix == ".png"
    ]
    return files
