"""Random-jerk Kalman filter (Ude eqs. 12-18) vs filterpy, OpenCV, closed forms and NEES."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import scipy.linalg
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter
from scipy import stats
from scipy.integrate import quad_vec

from humimic.estimation.random_jerk import (
    B_PAPER_SI,
    INIT_ACC_VAR,
    INIT_VEL_VAR,
    RandomJerkFilter,
    initial_state,
    predict,
    process_noise,
    transition,
    update,
)
from humimic.maths.kinematics import ca_predict
from humimic.maths.stats import nees

# filterpy's block_size=3, order_by_dim=True orders [px, vx, ax, py, vy, ay, pz, vz, az];
# ours is [px, py, pz, vx, vy, vz, ax, ay, az]. ours[i] == filterpy[PERM[i]].
PERM = np.array([0, 3, 6, 1, 4, 7, 2, 5, 8])

# Continuous model of eq. 13: x' = F x + G phi.
F_CONT = np.zeros((9, 9))
F_CONT[0:3, 3:6] = np.eye(3)
F_CONT[3:6, 6:9] = np.eye(3)
G_CONT = np.vstack([np.zeros((6, 3)), np.eye(3)])


def _random_spd(rng, n, scale):
    A = rng.normal(size=(n, n))
    return scale * (A @ A.T + n * np.eye(n)) / n


def test_transition_is_matrix_exponential():
    for dt in (0.0, 1 / 60, 0.05, 0.7):
        np.testing.assert_allclose(transition(dt), scipy.linalg.expm(F_CONT * dt), atol=1e-13)


@pytest.mark.parametrize("dt", [1 / 120, 1 / 60, 0.1, 0.5])
def test_process_noise_matches_integral_and_van_loan(dt):
    b = B_PAPER_SI
    Qc = b * b * np.eye(3)  # Ude eq. 12: spectral density b^2 I

    def integrand(s):
        E = scipy.linalg.expm(F_CONT * s)
        return E @ G_CONT @ Qc @ G_CONT.T @ E.T

    Q_int, _ = quad_vec(integrand, 0.0, dt, epsabs=0.0, epsrel=1e-12)
    # Van Loan (1978): expm([[-F, G Qc G^T], [0, F^T]] dt) = [[., Phi^-1 Q], [0, Phi^T]].
    M = np.zeros((18, 18))
    M[:9, :9] = -F_CONT
    M[:9, 9:] = G_CONT @ Qc @ G_CONT.T
    M[9:, 9:] = F_CONT.T
    E = scipy.linalg.expm(M * dt)
    Phi = E[9:, 9:].T
    Q_vl = Phi @ E[:9, 9:]
    Q = process_noise(dt, b)
    scale = np.abs(Q).max()
    np.testing.assert_allclose(Q, Q_int, rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(Q, Q_vl, rtol=1e-8, atol=1e-12 * scale)


def test_b_si_is_paper_mm_value_rescaled():
    # Q in mm^2 with b=27500 must equal Q in m^2 with b=27.5 times 1e6 (for every block).
    dt = 1 / 60
    np.testing.assert_allclose(process_noise(dt, 27500.0), 1e6 * process_noise(dt, B_PAPER_SI))


def _hand(t):
    return np.array([0.3 * np.sin(2.0 * t), 0.2 * np.cos(3.0 * t), 1.0 + 0.1 * np.sin(t)])


def _filterpy(x0, P0):
    kf = KalmanFilter(dim_x=9, dim_z=3)
    kf.x = x0[PERM].reshape(9, 1).copy()
    kf.P = P0[np.ix_(PERM, PERM)].copy()
    kf.H = np.zeros((3, 9))
    kf.H[[0, 1, 2], [0, 3, 6]] = 1.0
    return kf


def _cv2(x0, P0):
    kf = cv2.KalmanFilter(9, 3, 0, cv2.CV_64F)
    kf.statePost = x0.reshape(9, 1).copy()
    kf.errorCovPost = P0.copy()
    kf.measurementMatrix = np.hstack([np.eye(3), np.zeros((3, 6))])
    return kf


def test_predict_update_agree_with_filterpy_and_opencv():
    rng = np.random.default_rng(1234)
    b = B_PAPER_SI
    # measurements: a smooth 3-D hand-like trajectory (m) plus noise, random dt (s)
    t = 0.0
    z0 = _hand(t) + rng.normal(scale=0.01, size=3)
    R0 = _random_spd(rng, 3, 1e-4)
    x, P = initial_state(z0, R0)
    fp = _filterpy(x, P)
    ocv = _cv2(x, P)
    for k in range(60):
        dt = float(rng.uniform(0.005, 0.1))
        t += dt
        x_prev, P_prev = x, P
        x, P = predict(x, P, dt, b)
        fp.F = np.kron(np.eye(3), np.array([[1, dt, dt * dt / 2], [0, 1, dt], [0, 0, 1]]))
        fp.Q = Q_continuous_white_noise(dim=3, dt=dt, spectral_density=b**2, block_size=3)
        fp.predict()
        # OpenCV's update is the standard form P - K H P (not Joseph); run freely it drifts
        # from the Joseph form by ~1e-8 after ~25 steps at this conditioning (P_aa/R ~ 1e8),
        # so each OpenCV step starts from our previous posterior: every single predict and
        # update is compared on the same inputs. filterpy (Joseph) runs free over the sequence.
        ocv.statePost = x_prev.reshape(9, 1).copy()
        ocv.errorCovPost = P_prev.copy()
        ocv.transitionMatrix = transition(dt)
        ocv.processNoiseCov = process_noise(dt, b)
        ocv.predict()
        # order_by_dim=False interleaves exactly like our state: a second, permutation-free check
        Q_interleaved = Q_continuous_white_noise(3, dt, b**2, block_size=3, order_by_dim=False)
        np.testing.assert_allclose(process_noise(dt, b), Q_interleaved, rtol=1e-12, atol=0)
        for ref_x, ref_P in ((fp.x[PERM, 0], fp.P[np.ix_(PERM, PERM)]),
                             (ocv.statePre[:, 0], ocv.errorCovPre)):
            np.testing.assert_allclose(x, ref_x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(P, ref_P, rtol=1e-9, atol=1e-9 * np.abs(P).max())
        if k % 5 == 3:  # a missed frame: prediction only
            continue
        z = _hand(t) + rng.normal(scale=0.01, size=3)
        R = _random_spd(rng, 3, 1e-4)
        x, P = update(x, P, z, R)
        fp.update(z.reshape(3, 1), R=R)
        ocv.measurementNoiseCov = R
        ocv.correct(z.reshape(3, 1))
        for ref_x, ref_P in ((fp.x[PERM, 0], fp.P[np.ix_(PERM, PERM)]),
                             (ocv.statePost[:, 0], ocv.errorCovPost)):
            np.testing.assert_allclose(x, ref_x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(P, ref_P, rtol=1e-9, atol=1e-9 * np.abs(P).max())


def test_filter_class_initialisation_gaps_and_extrapolation():
    kf = RandomJerkFilter(b=B_PAPER_SI)
    assert kf.step(0.0) is None and not kf.initialised
    R = np.diag([1e-6, 2e-6, 4e-5])
    kf.step(0.1, [0.1, 0.2, 1.0], R)
    np.testing.assert_array_equal(kf.position, [0.1, 0.2, 1.0])
    np.testing.assert_array_equal(kf.P[:3, :3], R)
    np.testing.assert_array_equal(np.diag(kf.P)[3:], [INIT_VEL_VAR] * 3 + [INIT_ACC_VAR] * 3)
    x1, P1 = kf.x, kf.P
    kf.step(0.1 + 1 / 60, [0.11, 0.2, 1.0], R)
    x_ref, P_ref = update(*predict(x1, P1, 1 / 60, B_PAPER_SI), [0.11, 0.2, 1.0], R)
    np.testing.assert_allclose(kf.x, x_ref, rtol=1e-12, atol=1e-15)
    x2, P2 = kf.x, kf.P
    xe, Pe = kf.predict_at(0.5)  # no mutation
    np.testing.assert_array_equal(kf.x, x2)
    assert kf.t == pytest.approx(0.1 + 1 / 60)
    xp, Pp = predict(x2, P2, 0.5 - kf.t, B_PAPER_SI)
    np.testing.assert_allclose(xe, xp, rtol=1e-12)
    kf.step(0.2)  # missed frame
    np.testing.assert_allclose(kf.x, predict(x2, P2, 0.2 - (0.1 + 1 / 60), B_PAPER_SI)[0])
    with pytest.raises(ValueError, match="backwards"):
        kf.step(0.1, [0, 0, 1], R)
    with pytest.raises(ValueError):
        kf.step(0.3, [np.nan, 0, 1], R)


def _simulate_nees(b_true, b_filter, n_runs, n_steps, rng, sigma_m):
    """Batched Monte Carlo: trajectories from the exact discrete random-jerk model."""
    R = np.diag(np.square(sigma_m))
    x_true = np.zeros((n_runs, 9))
    x_true[:, 3:6] = rng.normal(scale=0.5, size=(n_runs, 3))
    z = x_true[:, :3] + rng.normal(size=(n_runs, 3)) * sigma_m
    x, P = initial_state(np.zeros(3), R)
    x = np.repeat(x[None], n_runs, 0)
    x[:, :3] = z
    P = np.repeat(P[None], n_runs, 0)
    # honest initial covariance: true v, a must be plausible under INIT_*_VAR (they are)
    out = []
    for _ in range(n_steps):
        dt = float(rng.uniform(1 / 90, 1 / 45))
        L = np.linalg.cholesky(process_noise(dt, b_true))
        x_true = x_true @ transition(dt).T + rng.normal(size=(n_runs, 9)) @ L.T
        z = x_true[:, :3] + rng.normal(size=(n_runs, 3)) * sigma_m
        x, P = predict(x, P, dt, b_filter)
        x, P = update(x, P, z, R)
        out.append(nees((x - x_true).reshape(-1, 9), P.reshape(-1, 9, 9)))
    return np.array(out)  # (n_steps, n_runs)


def test_filter_is_consistent_on_random_jerk_trajectories():
    n_runs = 400
    sigma_m = np.array([0.003, 0.004, 0.02])
    e = _simulate_nees(B_PAPER_SI, B_PAPER_SI, n_runs, 120, np.random.default_rng(7), sigma_m)
    # At the last step the runs are independent: mean NEES ~ chi2(9 n)/n. Two-sided 99.9 %.
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], 9 * n_runs) / n_runs
    assert lo < e[-1].mean() < hi, (lo, e[-1].mean(), hi)
    # negative control: a filter whose b is 3x too small is overconfident and fails the bound
    e_bad = _simulate_nees(B_PAPER_SI, B_PAPER_SI / 3, n_runs, 120, np.random.default_rng(7),
                           sigma_m)
    assert e_bad[-1].mean() > hi


def test_filter_on_sinusoid_is_not_overconfident_and_smooths():
    rng = np.random.default_rng(11)
    sigma_m = np.array([0.003, 0.008, 0.035])  # Table 3 raw std, in metres
    R = np.diag(sigma_m**2)
    t = np.cumsum(rng.uniform(1 / 70, 1 / 50, size=600))
    w = 2 * np.pi * 0.8
    amp = np.array([0.15, 0.1, 0.05])
    p = amp * np.sin(w * t[:, None]) + np.array([0.0, 0.2, 1.0])
    v = amp * w * np.cos(w * t[:, None])
    a = -amp * w**2 * np.sin(w * t[:, None])
    x_true = np.hstack([p, v, a])
    zs = p + rng.normal(size=p.shape) * sigma_m
    kf = RandomJerkFilter(b=B_PAPER_SI)
    est, covs = [], []
    for ti, zi in zip(t, zs, strict=True):
        kf.step(ti, zi, R)
        est.append(kf.x)
        covs.append(kf.P)
    est, covs = np.array(est)[60:], np.array(covs)[60:]
    e = nees(est - x_true[60:], covs)
    # smooth true motion has far less jerk than the model allows: NEES below dim, not above
    assert e.mean() < 9.0
    raw_rmse = np.sqrt(np.mean((zs[60:] - p[60:]) ** 2, axis=0))
    filt_rmse = np.sqrt(np.mean((est[:, :3] - p[60:]) ** 2, axis=0))
    assert np.all(filt_rmse < 0.9 * raw_rmse)  # measured 0.83, 0.75, 0.67, (filt_rmse, raw_rmse)


def test_transition_matrix_is_the_constant_acceleration_prediction():
    """Ude eq. 15's A(dt) applied to x is humimic.maths.kinematics.ca_predict (one model)."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=9)
    for dt in (0.0, 1 / 60, 0.37):
        np.testing.assert_allclose(transition(dt) @ x,
                                   np.concatenate(ca_predict(x[:3], x[3:6], x[6:], dt)),
                                   atol=1e-15)
