"""`fallbench report`: the answer first (rankings with intervals per robot and family), rendered falls,
the papers' figures and claims; index.html, one page per family, and summary.md. build.py
orchestrates; family_page.py, index_page.py and summary_page.py write the pages; papers/ holds the
papers' parts."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fallbench.report.build import build_report
    from fallbench.report.sections import PAPER_FIGURES, Options

__all__ = ["PAPER_FIGURES", "Options", "build_report"]


def __getattr__(name: str):
    """`build_report`, `Options` and `PAPER_FIGURES` on first use: a drawing worker imports the
    modules of its figures only, not every page's (scipy, the dynamics, the direction method)."""
    if name == "build_report":
        from fallbench.report.build import build_report

        return build_report
    if name in ("Options", "PAPER_FIGURES"):
        import fallbench.report.sections as sections

        return getattr(sections, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
