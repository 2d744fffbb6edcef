"""Statistics the report states its answers with: bootstrap confidence intervals, and the
natural order of swept values (`height=1` after `0.75`, before `1.25`)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
RESAMPLES = 2000
SEED = 0  # fixed: the same store gives the same report, bit for bit


@dataclass(frozen=True)
class Estimate:
    """A statistic of a sample with its bootstrap interval (NaN bounds when n < 2)."""

    value: float
    low: float
    high: float
    n: int

    def __str__(self) -> str:
        return self.format()

    def format(self, digits: int = 3) -> str:
        if np.isnan(self.value):
            return "n/a"
        value = _fmt(self.value, digits)
        if np.isnan(self.low):
            return f"{value} (n={self.n})"
        return f"{value} [{_fmt(self.low, digits)}, {_fmt(self.high, digits)}]"

    def disjoint(self, other: Estimate) -> bool:
        """Whether the two intervals do not overlap (a difference the data support)."""
        return bool(self.high < other.low or other.high < self.low)


def _fmt(value: float, digits: int) -> str:
    return f"{value:.{digits}g}" if abs(value) < 10**digits else f"{value:.0f}"


def bootstrap(
    values,
    statistic: str = "median",
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = SEED,
) -> Estimate:
    """The sample's median (or mean) and its percentile-bootstrap interval over resampled values,
    with a seeded generator so that the report is deterministic; the values are sorted first, so
    that the interval does not depend on their order (the order runs finished in). NaNs are dropped."""
    data = np.asarray(values, dtype=float)
    data = np.sort(data[~np.isnan(data)])
    function = {"median": np.median, "mean": np.mean}[statistic]
    if len(data) == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0)
    value = float(function(data))
    if len(data) < 2 or np.all(data == data[0]):
        low = high = value if len(data) >= 2 else float("nan")
        return Estimate(value, low, high, len(data))
    low, high = _interval(data.tobytes(), statistic, confidence, resamples, seed)
    return Estimate(value, low, high, len(data))


@cache
def _interval(
    data: bytes, statistic: str, confidence: float, resamples: int, seed: int
) -> tuple[float, float]:
    """The percentile-bootstrap interval of sorted float64 values (as bytes: the report asks for
    the same sample's interval more than once, e.g. a paired change in its ranking and its forest)."""
    result = stats.bootstrap(
        (np.frombuffer(data),),
        {"median": np.median, "mean": np.mean}[statistic],
        n_resamples=resamples,
        confidence_level=confidence,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(seed),
    )
    interval = result.confidence_interval
    return float(interval.low), float(interval.high)


_NUMBER = re.compile(r"(-?\d+(?:\.\d+)?(?:e-?\d+)?)")


def natural_key(text: str) -> tuple:
    """Sort key that compares the numbers inside a text by value: `h=0.75` < `h=1` < `h=1.25`."""
    parts = _NUMBER.split(str(text))
    return tuple((0, float(p), "") if i % 2 else (1, 0.0, p) for i, p in enumerate(parts))


def natural_sorted(texts) -> list:
    return sorted(texts, key=natural_key)
