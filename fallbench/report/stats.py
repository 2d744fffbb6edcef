"""Statistics the report states its answers with: bootstrap confidence intervals, and the
natural order of swept values (`height=1` after `0.75`, before `1.25`)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache

import numpy as np

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
    the same sample's interval more than once, e.g. a paired change in its ranking and its forest).
    The same numbers as `scipy.stats.bootstrap(..., method="percentile", vectorized=True,
    rng=np.random.default_rng(seed))`, bit for bit: the same resamples (`_resamples`), the same
    statistic over them and scipy's default ("linear") quantiles of their distribution, without
    scipy's checks and its import (1 ms a call, 0.9 s to import)."""
    sample = np.frombuffer(data)
    distribution = {"median": np.median, "mean": np.mean}[statistic](
        sample[_resamples(len(sample), resamples, seed)], axis=-1
    )
    if np.isnan(distribution).any():  # e.g. inf - inf in a mean: scipy's own NaN handling
        return _scipy_interval(sample, statistic, confidence, resamples, seed)
    alpha = (1 - confidence) / 2
    return _quantile(np.sort(distribution), alpha), _quantile(np.sort(distribution), 1 - alpha)


@cache
def _resamples(n: int, resamples: int, seed: int) -> np.ndarray:
    """The indices of the bootstrap's resamples of n values, (resamples, n): those scipy draws
    from a fresh `default_rng(seed)` (they depend only on n, so each n is drawn once)."""
    return np.random.default_rng(seed).integers(0, n, size=(resamples, n), dtype="int64")


def _quantile(ordered: np.ndarray, p: float) -> float:
    """`scipy.stats.quantile(x, p)` (method "linear") of sorted values, written as scipy computes
    it: the index p n + (1 - p) split into its integer and fractional parts."""
    n = float(len(ordered))
    position = p * n + (1 - p)
    above = position // 1
    below = above - 1
    fraction = 0.0 if below < 0 else position % 1
    below, above = min(max(below, 0.0), n - 1), min(max(above, 0.0), n - 1)
    return float((1 - fraction) * ordered[int(below)] + fraction * ordered[int(above)])


def _scipy_interval(
    sample: np.ndarray, statistic: str, confidence: float, resamples: int, seed: int
) -> tuple[float, float]:
    from scipy import stats

    result = stats.bootstrap(
        (sample,),
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
