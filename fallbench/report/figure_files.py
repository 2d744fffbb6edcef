"""Figure files shared by every page: PNG (and SVG with `fallbench report --svg`) with fixed DPI
and compression, the time-series envelope the line plots draw, and the error a figure that cannot
be drawn raises."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

DPI = 110
PNG_COMPRESSION = 3  # zlib: the same pixels as the default 6, files 2 % larger, saved ~40 % faster
PLOT_BUCKETS = 800  # min/max pairs a time series keeps (`envelope`): about the axes' width in pixels
MARGINS = {"left": 0.11, "right": 0.97, "bottom": 0.12, "top": 0.91, "hspace": 0.35, "wspace": 0.22}
_VECTOR = [False]  # whether `save_figure` also writes an SVG (`fallbench report --svg`); set per process


class FigureSkipped(RuntimeError):
    """A figure that cannot be drawn (no OpenGL context, no replay): its message is the note."""


def set_vector(vector: bool) -> bool:
    """Write an SVG next to each PNG from now on (in this process), or not; returns the setting before."""
    before, _VECTOR[0] = _VECTOR[0], vector
    return before


def envelope(t: np.ndarray, y: np.ndarray, buckets: int = PLOT_BUCKETS) -> tuple[np.ndarray, np.ndarray]:
    """The samples a line of `buckets` pixels can show: in each of `buckets` equal runs of samples
    its smallest and its largest value, in time order (peaks, e.g. the IMU's landing spike, are
    kept exactly; a series of at most 2 x `buckets` samples is returned as it is)."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if len(y) <= 2 * buckets:
        return t, y
    per = -(-len(y) // buckets)  # samples per bucket, the last one padded with its final value
    padded = np.concatenate([y, np.full(per * buckets - len(y), y[-1])]).reshape(buckets, per)
    base = np.arange(buckets) * per
    low = base + np.argmin(np.where(np.isnan(padded), np.inf, padded), axis=1)
    high = base + np.argmax(np.where(np.isnan(padded), -np.inf, padded), axis=1)
    keep = np.unique(np.minimum(np.concatenate([low, high]), len(y) - 1))
    return t[keep], y[keep]


def plot_series(ax, t, y, **style) -> None:
    """`ax.plot` of a time series through `envelope` (what the PNG shows is the same, drawn faster)."""
    ax.plot(*envelope(t, y), **style)


def save_figure(fig, out: Path, stem: str, margins: dict[str, float] | None = None) -> list[Path]:
    """Write the figure as `<stem>.png` (and `<stem>.svg` after `set_vector(True)`), then close it.
    With `margins` (MARGINS' keys, fractions of the figure) its subplots get fixed margins, else
    tight_layout's: laying the tick labels out takes a third of a simple figure's drawing time."""
    if margins is None:
        fig.tight_layout()
    else:
        fig.subplots_adjust(**(MARGINS | margins))
    paths = [out / f"{stem}.png"] + ([out / f"{stem}.svg"] if _VECTOR[0] else [])
    fig.savefig(paths[0], dpi=DPI, pil_kwargs={"compress_level": PNG_COMPRESSION})
    for path in paths[1:]:
        fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return paths


def files_only() -> None:
    """Draw with Agg, matplotlib's file-only backend: called where the report, its drawing workers
    and `fallbench compare` start drawing, so that importing the report opens no screen."""
    matplotlib.use("Agg")
