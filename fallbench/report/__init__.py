"""`fallbench report`: the answer first (rankings with intervals per robot and family), rendered falls,
the papers' figures and claims; index.html, one page per family, and summary.md. build.py
orchestrates; family_page.py, index_page.py and summary_page.py write the pages; papers/ holds the
papers' parts."""

from fallbench.report.build import build_report
from fallbench.report.sections import PAPER_FIGURES, Options

__all__ = ["PAPER_FIGURES", "Options", "build_report"]
