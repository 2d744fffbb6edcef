"""HTML pages of the report: an overview that answers first, and one page per scenario family.
Figures are linked files (`<img src>`), not embedded, so that pages load quickly."""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd

STYLE = (
    "body{font-family:sans-serif;max-width:1200px;margin:auto;padding:0 1em}table{border-collapse:collapse;margin:0.5em 0}"
    "td,th{border:1px solid #ccc;padding:3px 6px;font-size:13px}th{background:#f3f3f3}"
    ".verdict{font-weight:bold;margin:0.3em 0}img{max-width:100%}details{margin:0.4em 0}summary{cursor:pointer}"
)


def page(title: str, body: list[str]) -> str:
    return (
        f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{STYLE}</style></head><body>" + "\n".join(body) + "</body></html>"
    )


def image(path: Path, out: Path) -> str:
    """A linked figure: the page holds its name, the browser loads it when it scrolls into view."""
    name = html.escape(str(path.relative_to(out)) if path.is_relative_to(out) else path.name)
    return f'<a href="{name}"><img src="{name}" alt="{html.escape(path.stem)}" loading="lazy"></a>'


def table(frame: pd.DataFrame, index: bool = False) -> str:
    return frame.to_html(index=index, border=0, na_rep="") if len(frame) else "<p>(no runs)</p>"


def family_file(robot: str, family: str) -> str:
    stem = "".join(c if c.isalnum() else "_" for c in (f"{robot}_{family}" if robot else family)).strip("_")
    return f"family_{stem}.html"


def link(href: str, text: str) -> str:
    return f'<a href="{html.escape(href)}">{html.escape(text)}</a>'


def write(path: Path, title: str, body: list[str]) -> Path:
    path.write_text(page(title, body))
    return path
