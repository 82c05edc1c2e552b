"""Confidence intervals of the Monte Carlo figures (spacerobot.system.mc_stats) against SciPy's
independent implementations (binomtest's Wilson and exact intervals, the beta and binomial
distributions) and against a simulation of their coverage."""
import math

import numpy as np
import pytest

from spacerobot.system.mc_stats import (bootstrap_ci, clopper_pearson, median_ci,
                                        normal_quantile, wilson)

stats = pytest.importorskip("scipy.stats")


@pytest.mark.parametrize("k, n", [(0, 1), (0, 20), (3, 40), (17, 20), (20, 20), (57, 60),
                                  (490, 500), (1, 2000)])
def test_two_sided_intervals_match_scipy(k, n):
    ci = stats.binomtest(k, n)
    for ours, method in ((wilson(k, n), "wilson"), (clopper_pearson(k, n), "exact")):
        ref = ci.proportion_ci(0.95, method)
        assert ours == pytest.approx((ref.low, ref.high), abs=1e-9), method


@pytest.mark.parametrize("k, n", [(0, 30), (0, 300), (2, 100), (5, 460)])
def test_one_sided_upper_bound_is_the_beta_quantile(k, n):
    """The exact one-sided upper bound is the beta(k + 1, n - k) 95 % quantile; for k = 0 it
    is 1 - 0.05^(1/n) (the rule of three: about 3/n)."""
    lo, up = clopper_pearson(k, n, one_sided=True)
    assert lo == 0.0 and up == pytest.approx(stats.beta.ppf(0.95, k + 1, n - k), abs=1e-9)
    if k == 0:
        assert up == pytest.approx(1 - 0.05 ** (1 / n), rel=1e-9)


def test_normal_quantile():
    for p in (1e-6, 0.025, 0.5, 0.975, 0.9995):
        assert normal_quantile(p) == pytest.approx(stats.norm.ppf(p), abs=1e-9)
    with pytest.raises(ValueError):
        normal_quantile(1.0)


def test_median_interval_is_the_order_statistics_table():
    """n = 20: the 95 % interval of the median lies between the 6th and 15th values (coverage
    95.9 %, from the binomial distribution); the coverage of the pair chosen is at least 95 %
    and that of the next narrower pair below it, for every n from 6 to 60."""
    x = np.arange(1.0, 21.0)
    assert median_ci(x) == (10.5, 6.0, 15.0)
    for n in range(6, 61):
        med, lo, hi = median_ci(np.arange(1.0, n + 1))
        j = int(lo)
        cover = stats.binom.cdf(n - j, n, 0.5) - stats.binom.cdf(j - 1, n, 0.5)
        assert hi == n + 1 - j and cover >= 0.95
        narrower = stats.binom.cdf(n - j - 1, n, 0.5) - stats.binom.cdf(j, n, 0.5)
        assert narrower < 0.95
    assert all(math.isnan(v) for v in median_ci([1.0, 2.0, 3.0, 4.0, 5.0])[1:])  # n too small
    # cases that never got there count as infinite times
    assert median_ci([1.0] * 10 + [math.inf] * 11)[0] == math.inf


@pytest.mark.slow
def test_median_interval_covers_as_promised():
    """Simulated coverage of the true median over 4000 samples of 25 exponential values:
    at least 95 % within its binomial standard error (4 x 0.34 %)."""
    rng = np.random.default_rng(7)
    true = math.log(2.0)
    hits = 0
    for _ in range(4000):
        _, lo, hi = median_ci(rng.exponential(size=25))
        hits += lo <= true <= hi
    assert hits / 4000 >= 0.95 - 4 * math.sqrt(0.95 * 0.05 / 4000)


def test_bootstrap_resamples_whole_cases():
    """Ten estimates per case that are all equal (perfectly correlated): the interval of their
    mean is that of n independent cases, mean +- 1.96 sd / sqrt(n) to within 15 %, not the ten
    times narrower one of 10 n independent estimates; the same seed gives the same interval."""
    rng = np.random.default_rng(3)
    n = 200
    values = rng.normal(size=n)
    groups = [np.full(10, v) for v in values]

    def mean(gs):
        return float(np.mean(np.concatenate(gs)))
    est, lo, hi = bootstrap_ci(groups, mean, draws=4000)
    half = 1.96 * values.std(ddof=1) / math.sqrt(n)
    assert est == pytest.approx(values.mean())
    assert (hi - lo) / 2 == pytest.approx(half, rel=0.15)
    assert bootstrap_ci(groups, mean, draws=500, seed=5) == bootstrap_ci(groups, mean, draws=500,
                                                                          seed=5)


@pytest.mark.parametrize("args", [(-1, 5), (6, 5), (0, 0)])
def test_bad_counts_refused(args):
    with pytest.raises(ValueError):
        wilson(*args)
    with pytest.raises(ValueError):
        clopper_pearson(*args)
