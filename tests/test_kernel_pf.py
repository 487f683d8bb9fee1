"""The kernel particle filter's maths (Schmidt et al. eqs. 11-13) against independent
computations: the Epanechnikov KDE's integral (scipy quadrature) and value (a per-point loop
with the closed-form kernel), the mean-shift vector against the KDE's numerical gradient
(scipy), mode seeking against scipy's optimiser on the KDE, the reweighting's ratio, and the
mixed propagation's shares and noise bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, optimize

from humimic.estimation.particles import kernel as kpf
from humimic.estimation.particles import kernel_groups as kg


def _kde_loop(x, s, w, h):
    """Eq. 11 point by point: sum_n w_n (d+2)/(2 V_d) (1 - |u|^2)_+ / prod(h), V_d = the unit
    ball's volume from its recurrence V_d = 2 pi / d V_{d-2}."""
    d = s.shape[1]
    vol = {0: 1.0, 1: 2.0}
    for k in range(2, d + 1):
        vol[k] = 2 * math.pi / k * vol[k - 2]
    out = 0.0
    for sn, wn in zip(s, w, strict=True):
        r2 = float(np.sum(((x - sn) / h) ** 2))
        if r2 < 1:
            out += wn * (d + 2) / (2 * vol[d]) * (1 - r2)
    return out / np.prod(h)


def _kde_broadcast(x, s, w, h):
    """:func:`_kde_loop` at every point of ``x`` by broadcasting (M, N, d) differences."""
    d = s.shape[1]
    vol = {0: 1.0, 1: 2.0}
    for k in range(2, d + 1):
        vol[k] = 2 * math.pi / k * vol[k - 2]
    r2 = np.sum(((x[:, None] - s[None]) / h) ** 2, axis=-1)
    return np.maximum(1 - r2, 0) @ w * (d + 2) / (2 * vol[d]) / np.prod(h)


@pytest.fixture
def cloud():
    rng = np.random.default_rng(3)
    s = np.vstack([rng.normal([0, 0], 0.4, (60, 2)), rng.normal([2.5, 1.0], 0.3, (30, 2))])
    w = rng.uniform(0.5, 1.5, len(s))
    return s, w / w.sum(), np.array([0.9, 0.7])


def test_kde_matches_loop_and_integrates_to_one(cloud):
    s, w, h = cloud
    x = np.array([[0.1, -0.2], [2.4, 1.1], [1.2, 0.5], [9.0, 9.0]])
    assert np.allclose(kpf.kde(x, s, w, h), [_kde_loop(p, s, w, h) for p in x], atol=1e-12)
    total, _ = integrate.quad(lambda u: kpf.kde(np.array([[u]]), np.array([[0.2]]), [1.0],
                                                [0.7])[0], -0.5, 0.9)
    assert total == pytest.approx(1.0, abs=1e-9)
    # 2-D: midpoint rule on a fine grid over the kernel's support box
    g = (np.arange(600) + 0.5) / 600 * 2 - 1
    gx, gy = np.meshgrid(g * h[0], g * h[1])
    dens = kpf.kde(np.column_stack([gx.ravel(), gy.ravel()]), np.zeros((1, 2)), [1.0], h)
    assert dens.sum() * (2 * h[0] / 600) * (2 * h[1] / 600) == pytest.approx(1.0, abs=1e-4)


def test_mean_shift_points_up_the_kde_gradient(cloud):
    """Epanechnikov: m(x) - x = h^2 / (d + 2) grad p(x) / p_flat(x), so the shift is along the
    KDE's gradient (scaled per dimension by h^2)."""
    s, w, h = cloud
    shifted = kpf.mean_shift(s, w, h)
    for n in range(0, len(s), 7):
        g = optimize.approx_fprime(s[n], lambda x: kpf.kde(x[None], s, w, h)[0], 1e-7)
        v = (shifted[n] - s[n]) / h ** 2
        cos = v @ g / (np.linalg.norm(v) * np.linalg.norm(g))
        # within 2e-6 rad of the numerical gradient (measured <= 5e-7; the bound was 2.6 deg)
        assert cos > 1.0 - 2e-12, (n, cos)


def test_mean_shift_iterations_reach_the_kde_maximum(cloud):
    """A point moved by repeated mean shift over a fixed set ends where scipy's optimiser finds
    the KDE's local maximum from the same start."""
    s, w, h = cloud
    x = np.array([0.5, 0.4])
    for _ in range(200):
        inside = np.sum(((s - x) / h) ** 2, 1) <= 1
        x = (w * inside) @ s / (w * inside).sum()
    best = optimize.minimize(lambda p: -kpf.kde(p[None], s, w, h)[0], np.array([0.5, 0.4]),
                             method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-12})
    assert kpf.kde(x[None], s, w, h)[0] == pytest.approx(-best.fun, rel=0.01)
    assert np.linalg.norm(x - best.x) < 0.05


def test_dominant_mode_is_the_heavier_cluster(cloud):
    s, w, h = cloud
    mode, peak = kpf.dominant_mode(s, w, h, 0.25 * h * 4)
    assert np.linalg.norm(mode - [0, 0]) < 0.08  # measured 0.036
    assert np.argmax(kpf.kde(s, s, w, h)) == peak


def test_kernel_reweighting_is_likelihood_times_prior_over_proposal(cloud):
    s, _, h = cloud
    lik = np.linspace(-3, 0, len(s))
    shifted = kpf.mean_shift(s, np.exp(lik) / np.exp(lik).sum(), h)
    lw = kpf.kernel_log_weights(lik, shifted, s, h)
    u = np.full(len(s), 1 / len(s))
    p = np.array([_kde_loop(x, s, u, h) for x in shifted])
    q = np.array([_kde_loop(x, shifted, u, h) for x in shifted])
    assert np.allclose(lw, lik + np.log(p) - np.log(q))


def test_kpf_modes_find_the_higher_of_two_peaks_where_the_mean_falls_between():
    """Two likelihood peaks (heights 1 and 1/2): mean shift and the dominant mode land on the
    higher one in most runs, while the weighted mean falls between them."""
    p1, p2 = np.array([0.5, 0.1, -0.1]), np.array([-0.5, 0.0, 0.2])
    h0 = np.full(3, 0.5)

    def log_lik(x):
        g1 = np.exp(-0.5 * np.sum(((x - p1) / 0.12) ** 2, 1))
        g2 = np.exp(-0.5 * np.sum(((x - p2) / 0.12) ** 2, 1))
        return np.log(g1 + 0.5 * g2 + 1e-300)

    mode_err, mean_err = [], []
    for seed in range(6):
        x0 = np.random.default_rng(seed).uniform(-1, 1, (400, 3))
        x, w, _, done = kpf.kpf_modes(x0, log_lik, h0, 3, tol=0.0)
        w = w[:, 0]
        assert done == 3
        mode, _ = kpf.dominant_mode(x, w, 0.8 ** 2 * h0, 0.25 * h0)
        mode_err.append(np.linalg.norm(mode - p1))
        mean_err.append(np.linalg.norm(w @ x - p1))
    assert np.median(mode_err) < 0.12 and np.median(mean_err) > 0.2, (mode_err, mean_err)
    assert np.sum(np.array(mode_err) < 0.15) >= 4


def test_mixed_propagation_shares_bounds_and_validity():
    rng = np.random.default_rng(1)
    x = np.zeros((1000, 2))
    D = np.array([1.0, 2.0])
    v = np.array([5.0, 0.0])
    out, moved = kpf.mixed_propagate(x, v, 0.3, D, rng, lambda q: q[:, 1] > -1.0)
    assert moved.sum() == 300
    assert np.all(np.abs(out[moved] - v) <= 0.25 * D + 1e-12)
    assert np.all(np.abs(out[~moved]) <= D + 1e-12)
    assert np.all(out[:, 1] > -1.0)                                 # re-drawn until valid
    assert np.std(out[~moved, 0]) == pytest.approx(1 / np.sqrt(3), rel=0.1)   # uniform +-D
    w = np.where(moved, 2.0, 0.1)
    assert kpf.motion_share(w, moved, 0.2) == pytest.approx(0.8)     # random share kept
    assert kpf.motion_share(np.where(moved, 1.0, 3.0), moved, 0.2) == pytest.approx(
        300 / (300 + 3 * 700))


@pytest.mark.parametrize("dedup_min", [0, kpf.DEDUP_MIN])
def test_duplicate_particles_and_single_precision_give_the_same_shift_and_weights(
        dedup_min, monkeypatch):
    """Coinciding particles are shifted once and merged as sources (always, with
    ``DEDUP_MIN = 0``), and the kernel sums may run in float32: mean shift, the KDE and the
    reweighting agree with a per-point loop over the unmerged float64 set (mean shift leaves
    many duplicates after its first iteration)."""
    monkeypatch.setattr(kpf, "DEDUP_MIN", dedup_min)
    rng = np.random.default_rng(5)
    base = rng.normal([0.3, -1.2, 2.0, 40.0], [0.4, 0.3, 0.5, 0.2], (120, 4))
    s = base[rng.integers(0, 120, 400)]                       # ~28 % distinct rows
    w = rng.uniform(0.2, 1.0, len(s))
    w /= w.sum()
    h = np.array([0.5, 0.4, 0.6, 0.3])
    loop = np.array([(w * (np.sum(((s - x) / h) ** 2, 1) <= 1)) @ s
                     / (w * (np.sum(((s - x) / h) ** 2, 1) <= 1)).sum() for x in s])
    for dtype, tol in ((np.float64, 1e-12), (np.float32, 1e-5)):
        assert np.allclose(kpf.mean_shift(s, w, h, dtype), loop, rtol=0, atol=tol)
        x = s[:40] + 0.05
        ref = _kde_broadcast(x, s, w, h)
        assert np.allclose(kpf.kde(x, s, w, h, dtype), ref, rtol=10 * tol, atol=0)
    lik = rng.normal(size=len(s))
    shifted = kpf.mean_shift(s, w, h)
    prior = base[rng.integers(0, 120, 400)] + rng.normal(0, 0.05, (400, 4))
    for stride in (1, 3):
        rp, rq = prior[::stride], shifted[::stride]
        p = _kde_broadcast(shifted, rp, np.full(len(rp), 1 / len(rp)), h)
        q = _kde_broadcast(shifted, rq, np.full(len(rq), 1 / len(rq)), h)
        if stride > 1:
            q = q * (1 - 1 / 400) + kpf.epanechnikov(0.0, 4) / np.prod(h) / 400
        with np.errstate(divide="ignore"):
            want = lik + np.log(p) - np.log(q)
        for dtype, tol in ((np.float64, 1e-9), (np.float32, 1e-4)):
            got = kpf.kernel_log_weights(lik, shifted, prior, h, stride, dtype)
            assert np.array_equal(np.isfinite(got), np.isfinite(want))
            ok = np.isfinite(want)
            assert np.allclose(got[ok], want[ok], rtol=0, atol=tol)


def test_groups_shift_reweight_and_find_modes_each_with_its_own_weights_in_one_pass():
    """Partitioned mode seeking (:func:`kg.mean_shift_groups`,
    :func:`kg.kernel_log_weights_groups`, one stacked pass for small sets): each group's
    dimensions move to the weighted mean of its own window (a per-point loop over that group
    with its weights; negligible weights left out) and get eq. 11's prior / proposal ratio
    from a broadcast KDE over that group's dimensions only; its dominant mode
    (:func:`kg.dominant_modes`) is the weighted mean of the window round its own KDE's peak."""
    rng = np.random.default_rng(11)
    groups = [np.arange(0, 3), np.arange(3, 5), np.arange(5, 7)]
    n = 100
    s = rng.normal(size=(30, 7))[rng.integers(0, 30, n)] + rng.normal(0, 0.2, (n, 7))
    W = rng.uniform(0.2, 1.0, (n, 3))
    W[:10, 1] = 1e-12                                   # negligible in group 1
    W /= W.sum(axis=0)
    h = rng.uniform(0.4, 0.9, 7)
    assert kg._batched(n, n, groups)
    want = np.empty_like(s)
    for k, g in enumerate(groups):
        w = np.where(W[:, k] > kpf.NEGLIGIBLE * W[:, k].max(), W[:, k], 0.0)
        for i, x in enumerate(s[:, g]):
            inside = w * (np.sum(((s[:, g] - x) / h[g]) ** 2, axis=1) <= 1.0)
            want[i, g] = inside @ s[:, g] / inside.sum()
    for dtype, tol in ((np.float64, 1e-12), (np.float32, 1e-5)):
        assert np.allclose(kg.mean_shift_groups(s, W, h, groups, dtype), want, rtol=0,
                           atol=tol)
    shifted = kg.mean_shift_groups(s, W, h, groups)
    prior = s + rng.normal(0, 0.1, s.shape)
    lik = rng.normal(size=(n, 3))
    for stride in (1, 4):
        want = np.empty((n, 3))
        for k, g in enumerate(groups):
            rp, rq = prior[::stride, g], shifted[::stride, g]
            p = _kde_broadcast(shifted[:, g], rp, np.full(len(rp), 1 / len(rp)), h[g])
            q = _kde_broadcast(shifted[:, g], rq, np.full(len(rq), 1 / len(rq)), h[g])
            if stride > 1:
                q = q * (1 - 1 / n) + kpf.epanechnikov(0.0, len(g)) / np.prod(h[g]) / n
            with np.errstate(divide="ignore"):
                want[:, k] = lik[:, k] + np.log(p) - np.log(q)
        ok = np.isfinite(want)
        for dtype, tol in ((np.float64, 1e-9), (np.float32, 1e-4)):
            got = kg.kernel_log_weights_groups(lik, shifted, prior, h, groups, stride, dtype)
            assert np.array_equal(np.isfinite(got), ok)
            assert np.allclose(got[ok], want[ok], rtol=0, atol=tol)
    # each group's dominant mode: the peak of its own KDE (broadcast), then the weighted mean
    # of its window
    window = 0.3 * h
    want = np.empty(7)
    for k, g in enumerate(groups):
        dens = _kde_broadcast(shifted[:, g], shifted[:, g], W[:, k], h[g])
        dens[W[:, k] <= kpf.NEGLIGIBLE * W[:, k].max()] = -np.inf
        peak = shifted[np.argmax(dens), g]
        near = W[:, k] * (np.sum(((shifted[:, g] - peak) / window[g]) ** 2, axis=1) <= 1.0)
        want[g] = near @ shifted[:, g] / near.sum()
    for dtype in (np.float64, np.float32):
        assert np.allclose(kg.dominant_modes(shifted, W, h, window, groups, dtype), want,
                           rtol=0, atol=1e-12)


def test_unique_rows_match_numpy_unique():
    """The distinct rows (first occurrences, in the order np.unique's stable sort gives them
    up to the key's order) and each row's representative agree with ``np.unique(axis=0)``."""
    rng = np.random.default_rng(2)
    for n in (0, 1, 2, 9, 300):
        m = max(n // 3, 1)
        q = rng.normal(size=(m, 5))[rng.integers(0, m, n)]
        first, inverse = kpf.unique_rows(q)
        _, first_np, _ = np.unique(q, axis=0, return_index=True, return_inverse=True)
        assert sorted(first) == sorted(first_np)          # the first occurrence of each row
        assert np.array_equal(q[first][inverse], q)


def test_unique_rows_falls_back_where_keys_collide_or_rows_hold_nan(monkeypatch):
    """Distinct rows sharing a key (every key equal: a zero projection) and NaN rows (never
    equal to themselves) fail the exact check: the result is ``np.unique(axis=0)``'s."""
    rng = np.random.default_rng(3)
    q = rng.normal(size=(4, 3))[rng.integers(0, 4, 30)]
    q_nan = q.copy()
    q_nan[5, 1] = np.nan
    for rows, key in ((q, np.zeros(64)), (q_nan, kpf._KEY)):
        monkeypatch.setattr(kpf, "_KEY", key)
        first, inverse = kpf.unique_rows(rows)
        _, first_np, inverse_np = np.unique(rows, axis=0, return_index=True,
                                            return_inverse=True)
        assert np.array_equal(first, first_np)
        assert np.array_equal(inverse, inverse_np.reshape(-1))
