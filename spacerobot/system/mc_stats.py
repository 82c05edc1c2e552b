"""Confidence intervals for the figures of a Monte Carlo study (fractions, medians, ratios over
cases).

Pure functions of numbers: no FMI, no Dask. A fraction of cases (within 1 %, flags wrong) is a
binomial proportion: :func:`wilson` (score interval, good coverage for any n) and
:func:`clopper_pearson` (exact: never below the nominal coverage; the bound to quote for a
rate that must stay below a limit, e.g. false flags). A median of cases: :func:`median_ci`
from the order statistics (distribution-free; a case that never reached its goal counts as
``inf``). A statistic of several estimates per case, which are correlated within the case
(the fraction of estimates within 2 sd, an efficiency): :func:`bootstrap_ci` resamples whole
cases.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence, Tuple

import numpy as np

__all__ = ["wilson", "clopper_pearson", "median_ci", "bootstrap_ci", "normal_quantile"]


def normal_quantile(p: float) -> float:
    """The standard normal distribution's ``p`` quantile (0 < p < 1), by bisection on
    ``erfc`` (to 1e-12)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"a probability in (0, 1) is needed, got {p}")
    lo, hi = -40.0, 40.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 0.5 * math.erfc(-mid / math.sqrt(2.0)) < p:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12:
            break
    return 0.5 * (lo + hi)


def _check(k: int, n: int, level: float) -> None:
    if not (n >= 1 and 0 <= k <= n):
        raise ValueError(f"need 0 <= k <= n and n >= 1, got k = {k}, n = {n}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"the confidence level must be in (0, 1), got {level}")


def wilson(k: int, n: int, level: float = 0.95) -> Tuple[float, float]:
    """Wilson's score interval of the proportion ``k / n`` (two-sided, ``level``)."""
    _check(k, n, level)
    z = normal_quantile(0.5 + level / 2.0)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def _binom_cdf(k: int, n: int, p: float) -> float:
    """P(X <= k) for X ~ Binomial(n, p), summed in log space."""
    if p <= 0.0:
        return 1.0
    if p >= 1.0:
        return 1.0 if k >= n else 0.0
    lp, lq = math.log(p), math.log1p(-p)
    terms = [math.lgamma(n + 1) - math.lgamma(i + 1) - math.lgamma(n - i + 1) + i * lp
             + (n - i) * lq for i in range(k + 1)]
    top = max(terms)
    return min(1.0, math.exp(top) * sum(math.exp(t - top) for t in terms))


def _solve(f: Callable[[float], float], target: float) -> float:
    """The p in [0, 1] where the decreasing f(p) crosses target (bisection, to 1e-12)."""
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if f(mid) > target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def clopper_pearson(k: int, n: int, level: float = 0.95,
                    one_sided: bool = False) -> Tuple[float, float]:
    """The exact (Clopper-Pearson) interval of the proportion ``k / n``: two-sided at
    ``level``, or with ``one_sided`` the interval ``[0, upper]`` whose upper bound holds with
    probability ``level`` (k = 0: ``1 - (1 - level)^(1/n)``, the "rule of three" 3/n at 95 %)."""
    _check(k, n, level)
    alpha = 1.0 - level
    tail = alpha if one_sided else alpha / 2.0
    # upper: P(X <= k | p) = tail; lower: P(X >= k | p) = tail, i.e. P(X <= k-1 | p) = 1 - tail
    upper = 1.0 if k == n else _solve(lambda p: _binom_cdf(k, n, p), tail)
    if one_sided:
        return 0.0, upper
    lower = 0.0 if k == 0 else _solve(lambda p: _binom_cdf(k - 1, n, p), 1.0 - tail)
    return lower, upper


def median_ci(x: Sequence[float], level: float = 0.95) -> Tuple[float, float, float]:
    """``(median, lower, upper)``: the sample median and the distribution-free interval of the
    population median between two order statistics, the narrowest pair symmetric in rank whose
    binomial coverage is at least ``level`` (``inf`` values count: a case that never reached
    its goal; an upper bound of ``inf`` says that more than the bound's share never did).
    NaN bounds when n is too small for the level."""
    v = np.sort(np.asarray(x, dtype=float))
    n = len(v)
    if n == 0:
        raise ValueError("no values")
    if np.isnan(v).any():
        raise ValueError("NaN among the values (give inf for 'never')")
    med = float(np.median(v)) if np.isfinite(np.median(v)) else math.inf
    # P(v_(j) <= median <= v_(n+1-j)) = 1 - 2 P(Binomial(n, 1/2) <= j - 1), ranks 1-based
    best = None
    for j in range(1, n // 2 + 1):
        if 1.0 - 2.0 * _binom_cdf(j - 1, n, 0.5) >= level:
            best = j
    if best is None:
        return med, math.nan, math.nan
    return med, float(v[best - 1]), float(v[n - best])


def bootstrap_ci(groups: Sequence, statistic: Callable[[Sequence], object],
                 level: float = 0.95, draws: int = 2000, seed: int = 0):
    """``(statistic, lower, upper)``: the statistic of ``groups`` (one item per case: its
    estimates, its row ...) and its percentile interval over ``draws`` resamplings of whole
    cases with replacement (the estimates of one case are correlated: resampling them singly
    would understate the spread); seeded, so the same groups give the same interval. A
    statistic that returns an array gives arrays (each entry's interval)."""
    if len(groups) == 0:
        raise ValueError("no cases")
    rng = np.random.default_rng(seed)
    n = len(groups)
    stats = np.array([statistic([groups[i] for i in rng.integers(0, n, n)])
                      for _ in range(draws)], dtype=float)
    a = (1.0 - level) / 2.0
    lo, hi = np.nanquantile(stats, a, axis=0), np.nanquantile(stats, 1.0 - a, axis=0)
    value = np.asarray(statistic(list(groups)), dtype=float)
    if value.ndim == 0:
        return float(value), float(lo), float(hi)
    return value, lo, hi
