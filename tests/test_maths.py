"""The shared maths against independent computations (scipy, closed forms)."""

import math

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.stats import chi2

from humimic.maths.kinematics import ca_predict
from humimic.maths.stats import chi2_band, fraction_in_band, nees, rmse


def test_rmse_skips_nan_rows_and_is_nan_when_empty():
    err = np.array([[3.0, 4.0, 0.0], [np.nan, 0.0, 0.0], [0.0, 0.0, 12.0]])
    assert rmse(err) == pytest.approx(math.sqrt((25.0 + 144.0) / 2))
    assert math.isnan(rmse(np.full((4, 3), np.nan)))
    assert math.isnan(rmse(np.zeros((0, 3))))
    assert rmse(np.array([1.0, -1.0, 1.0])) == pytest.approx(1.0)
    # empty scalars and empty (N, 3, 3) rows: NaN, not reshape's error
    assert math.isnan(rmse(np.zeros(0))) and math.isnan(rmse(np.zeros((0, 3, 3))))
    assert rmse(np.ones((2, 2, 2))) == pytest.approx(2.0)  # each row's norm sqrt(4)


def test_nees_matches_explicit_inverse_and_flags_singular():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(50, 3, 3))
    P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)
    e = rng.normal(size=(50, 3))
    want = [e[k] @ np.linalg.inv(P[k]) @ e[k] for k in range(50)]
    np.testing.assert_allclose(nees(e, P), want, rtol=1e-9)
    P[7] = 0.0
    out = nees(e, P)
    assert math.isnan(out[7]) and np.isfinite(np.delete(out, 7)).all()


def test_nees_in_blocks_matches_explicit_inverse_across_block_edges():
    from humimic.maths.stats import NEES_BLOCK

    rng = np.random.default_rng(2)
    n = 2 * NEES_BLOCK + 5
    A = rng.normal(size=(n, 3, 3))
    P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)
    e = rng.normal(size=(n, 3))
    P[NEES_BLOCK + 1] = 0.0                                   # singular, in the second block
    e[2 * NEES_BLOCK + 2, 0] = np.nan                        # not finite, in the third
    want = np.einsum("ni,nij,nj->n", e, np.linalg.pinv(P), e)
    want[[NEES_BLOCK + 1, 2 * NEES_BLOCK + 2]] = np.nan
    np.testing.assert_allclose(nees(e, P), want, rtol=1e-8)


def test_nees_of_consistent_samples_is_chi_square():
    rng = np.random.default_rng(1)
    L = np.array([[0.2, 0, 0], [0.05, 0.1, 0], [0.0, 0.02, 0.3]])
    P = L @ L.T
    e = rng.normal(size=(20000, 3)) @ L.T
    v = nees(e, P)
    assert v.mean() == pytest.approx(3.0, rel=0.03)
    lo, hi = chi2_band(3)
    assert (lo, hi) == pytest.approx((chi2.ppf(0.025, 3), chi2.ppf(0.975, 3)))
    assert fraction_in_band(v, 3) == pytest.approx(0.95, abs=0.01)


def test_ca_predict_is_the_exact_flow_of_the_constant_acceleration_model():
    # x' = F x with x = (p, v, a): the prediction is expm(F dt) x.
    F = np.kron(np.array([[0, 1, 0], [0, 0, 1], [0, 0, 0]]), np.eye(3))
    p, v, a = np.array([1.0, 2, 3]), np.array([-0.5, 0.2, 0.1]), np.array([0.3, -9.81, 0.0])
    for dt in (0.0, 0.01, 0.7):
        want = expm(F * dt) @ np.concatenate([p, v, a])
        got = np.concatenate(ca_predict(p, v, a, dt))
        np.testing.assert_allclose(got, want, atol=1e-12)
    dts = np.array([0.1, 0.2])
    P2, V2, _ = ca_predict(np.stack([p, p]), np.stack([v, v]), np.stack([a, a]), dts)
    np.testing.assert_allclose(P2[1], ca_predict(p, v, a, 0.2)[0])


def test_chi2_band_of_window_means_holds_95_percent_of_consistent_windows():
    """Monte Carlo: NEES of errors drawn from P, averaged over windows, fall inside the band
    of the mean ~95 % of the time; a filter whose P is 4x too small falls outside."""
    rng = np.random.default_rng(1)
    n, window, dof = 21_000, 30, 9
    A = rng.normal(size=(dof, dof))
    P = A @ A.T + dof * np.eye(dof)
    e = rng.multivariate_normal(np.zeros(dof), P, size=n)
    lo, hi = chi2_band(dof, window)
    means = nees(e, P).reshape(-1, window).mean(axis=1)
    assert 0.93 < np.mean((means >= lo) & (means <= hi)) < 0.97
    over = nees(e, P / 4).reshape(-1, window).mean(axis=1)
    assert np.mean((over >= lo) & (over <= hi)) < 0.01


def test_sum_squares_add_over_blocks_to_the_whole_rmse():
    """rmse's partial sums over blocks (NaN rows skipped in each) give the whole array's RMS,
    computed here directly, to rounding."""
    from humimic.maths.stats import rms_of, sum_squares

    rng = np.random.default_rng(7)
    err = rng.normal(size=(9001, 3))
    err[rng.choice(9001, 50, replace=False), 0] = np.nan
    ok = np.all(np.isfinite(err), axis=1)
    direct = math.sqrt(np.mean(np.linalg.norm(err[ok], axis=1) ** 2))
    sums = [sum_squares(err[a:a + 1000]) for a in range(0, 9001, 1000)]
    total, count = sum(s[0] for s in sums), sum(s[1] for s in sums)
    assert count == ok.sum()
    assert rms_of(total, count) == pytest.approx(direct, rel=1e-12)
    assert rmse(err) == pytest.approx(direct, rel=1e-12)
    assert math.isnan(rms_of(0.0, 0))
