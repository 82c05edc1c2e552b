"""The prior's pull and the a-posteriori residual variance (oracles.estimator.uncertainty),
against batch least squares computed directly."""
import numpy as np
import pytest

from oracles.estimator.rls import RLS
from oracles.estimator.uncertainty import Gram, prior_pull, residual_variance


def batch(Hs, ys, x0, P0, lam):
    """Regularised and data-only least squares, written out over all stored samples."""
    N = len(Hs)
    G = sum(lam ** (N - 1 - k) * H.T @ H for k, H in enumerate(Hs))
    g = sum(lam ** (N - 1 - k) * H.T @ y for k, (H, y) in enumerate(zip(Hs, ys)))
    W0 = lam ** N * np.linalg.inv(P0)
    x_reg = np.linalg.solve(W0 + G, g + W0 @ x0)
    x_ls = np.linalg.lstsq(G, g, rcond=None)[0]
    return x_reg, x_ls, G


@pytest.mark.parametrize("lam", [1.0, 0.98])
def test_prior_pull_is_the_distance_to_the_data_only_answer(lam):
    rng = np.random.default_rng(1)
    p = 6
    x_true = rng.normal(size=p) * [500, 50, 50, 50, 10, 10]
    x0 = x_true * rng.uniform(0.5, 1.5, p)
    P0 = 1e2 * np.eye(p)                  # a strong prior: a pull well above round-off
    rls = RLS(x0, P0, lam)
    gram = Gram.empty(p, lam)
    Hs, ys = [], []
    for k in range(40):
        H = rng.normal(size=(3, p)) * np.geomspace(1, 1e-3, p)   # poorly scaled columns
        y = H @ x_true
        rls.update(H, y)
        gram = gram.add(H)
        Hs.append(H), ys.append(y)
    x_reg, x_ls, G = batch(Hs, ys, x0, P0, lam)
    assert np.allclose(gram.S, G, rtol=1e-12, atol=0)
    W0 = gram.decay * np.linalg.inv(P0)
    # the prior's remaining weight is what separates the covariance from the information
    assert np.allclose(np.linalg.inv(rls.P) - G, W0, rtol=1e-6, atol=1e-9)
    assert np.allclose(rls.x, x_reg, rtol=1e-9, atol=1e-9 * np.abs(x_true).max())
    delta, unobserved = prior_pull(W0, G, rls.x, x0)
    assert not unobserved.any()
    assert np.abs(rls.x - x_true).max() > 1e-6        # the prior did pull
    # noise-free: the data-only answer is the truth, so the pull is the error itself
    assert np.allclose(delta, rls.x - x_true, rtol=1e-6, atol=1e-8 * np.abs(x_true).max())
    assert np.allclose(delta, x_reg - x_ls, rtol=1e-6, atol=1e-8 * np.abs(x_true).max())


def test_unobserved_directions_are_flagged():
    rng = np.random.default_rng(2)
    p = 4
    x0 = np.ones(p)
    rls = RLS(x0, 1e6 * np.eye(p))
    G = np.zeros((p, p))
    for _ in range(20):
        H = rng.normal(size=(2, p))
        H[:, 3] = 0.0                       # parameter 4 never appears
        H[:, 2] = H[:, 1]                   # parameters 2 and 3 only as their sum
        rls.update(H, H @ np.array([2.0, 3.0, 4.0, 5.0]))
        G += H.T @ H
    delta, unobserved = prior_pull(1e-6 * np.eye(p), G, rls.x, x0)
    assert list(unobserved) == [False, True, True, True]
    assert np.isfinite(delta).all()


def test_residual_variance_from_the_gram_matrix():
    rng = np.random.default_rng(3)
    p, sigma = 5, 0.3
    x_true = rng.normal(size=p)
    gram = Gram.empty(p + 1, lam=0.99)
    Hs, ys = [], []
    for _ in range(300):
        H = rng.normal(size=(3, p))
        y = H @ x_true + sigma * rng.normal(size=3)
        gram = gram.add(np.column_stack([H, y]))
        Hs.append(H), ys.append(y)
    x = rng.normal(size=p)
    N = len(Hs)
    ssr = sum(0.99 ** (N - 1 - k) * np.sum((y - H @ x) ** 2) for k, (H, y) in enumerate(zip(Hs, ys)))
    assert residual_variance(gram.S, np.append(x, -1.0), gram.rows, p) == pytest.approx(
        ssr / (3 * N - p), rel=1e-10)
    # at the least-squares answer (no forgetting) the variance estimates sigma^2
    g1 = Gram.empty(p + 1)
    for H, y in zip(Hs, ys):
        g1 = g1.add(np.column_stack([H, y]))
    x_ls = np.linalg.solve(g1.S[:p, :p], g1.S[:p, p])
    s2 = residual_variance(g1.S, np.append(x_ls, -1.0), g1.rows, p)
    assert s2 == pytest.approx(sigma ** 2, rel=0.15)
    assert residual_variance(g1.S, np.append(x_ls, -1.0), p, p) == 0.0   # no redundancy yet
