"""What `fallbench report` is asked for (`Options`) and everything its pages show, computed once
(`Sections`: figure paths and tables)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from fallbench.report.drawing import Drawn, Figure
from fallbench.report.family import Family
from fallbench.report.forest import Pool

PAPER_FIGURES = ("chosen", "all")  # `fallbench report --paper-figures`


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


@dataclass
class Sections:
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
