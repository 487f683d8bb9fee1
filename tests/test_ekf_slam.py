"""The EKF SLAM core on synthetic data (no images): its sparse steps against filterpy's dense
Kalman filter and unscented transform, NEES against the chi-square band, map management."""

from __future__ import annotations

import _synth_slam as synth
import numpy as np
import pytest
from filterpy.kalman import KalmanFilter, MerweScaledSigmaPoints, unscented_transform
from test_ekf_jacobians import sugiyama_eq3

from humimic.estimation.ekf import inverse_depth as idp
from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import update as up
from humimic.estimation.ekf.slam import SlamFilter
from humimic.maths.stats import chi2_band, nees, rmse


def _random_cov(rng, n):
    A = rng.standard_normal((n, n))
    return A @ A.T / n + 0.1 * np.eye(n)


def _filter_with_map(rng) -> SlamFilter:
    x0 = mm.initial_state(p=[0.1, 0.0, -2.5], q=[1, 0, 0, 0], v=[0.2, 0, 0.1])
    f = SlamFilter(0.0, x0, _random_cov(rng, mm.DIM) * 1e-3, synth.INTR, synth.R_CV_I)
    f.add_known(synth.SCREEN, sigma=0.01)
    f.add_features(np.array([[50.0, 60.0], [200.0, 100.0], [300.0, 200.0]]))
    f.P = _random_cov(rng, len(f.x)) * 1e-3  # a dense, correlated covariance
    return f


def test_feature_update_matches_filterpy():
    rng = np.random.default_rng(1)
    f = _filter_with_map(rng)
    pred = f.predict_features()
    assert len(pred.fids) == 7  # 4 corners + 3 new features, all in view
    matched = np.array([0, 2, 4, 5, 6])
    z = pred.uv[matched] + rng.standard_normal((5, 2))
    # the dense reference: H from the same Jacobians, scattered into (10, n)
    n = len(f.x)
    H = np.zeros((10, n))
    for r, i in enumerate(matched):
        feat = f.feature(int(pred.fids[i]))
        y = f.x[feat.offset:feat.offset + feat.dim][None]
        _, Hpq, Hy, _ = idp.observe(y, f.x[0:3], f.x[3:7], f.intr, f.R_cv_I)
        H[2 * r:2 * r + 2, 0:7] = Hpq[0]
        H[2 * r:2 * r + 2, feat.offset:feat.offset + feat.dim] = Hy[0]
    kf = KalmanFilter(dim_x=n, dim_z=10)
    kf.x, kf.P, kf.H, kf.R = f.x.copy(), f.P.copy(), H, np.eye(10)
    S_ref = H @ f.P @ H.T + np.eye(10)
    rows = (2 * matched[:, None] + np.arange(2)).ravel()
    np.testing.assert_allclose(pred.S_full[np.ix_(rows, rows)], S_ref, rtol=1e-10, atol=1e-12)
    h = pred.uv[matched].ravel()
    kf.update(z.ravel() - h + H @ f.x)  # linearised: z - h(x) = H (x_true - x)
    f.update_features(pred, matched, z)
    # our update renormalises q (a projection filterpy does not make): compare before that
    np.testing.assert_allclose(f.x[7:], kf.x[7:], rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(f.x[0:3], kf.x[0:3], rtol=1e-8, atol=1e-10)


def test_inertial_update_matches_filterpy():
    rng = np.random.default_rng(2)
    f = _filter_with_map(rng)
    q_meas = f.x[3:7] + 1e-3 * rng.standard_normal(4)
    a_meas = rng.standard_normal(3)
    n = len(f.x)
    H = np.zeros((7, n))
    H[0:4, 3:7] = np.eye(4)
    H[4:7, 13:16] = H[4:7, 16:19] = np.eye(3)
    kf = KalmanFilter(dim_x=n, dim_z=7)
    kf.x, kf.P, kf.H = f.x.copy(), f.P.copy(), H
    kf.R = np.diag(np.r_[np.full(4, 1e-6), np.full(3, 0.25)])
    kf.update(np.r_[q_meas, a_meas])
    P_before = f.P.copy()
    f.update_inertial(q_meas, a_meas)
    np.testing.assert_allclose(f.x[7:], kf.x[7:], rtol=1e-8, atol=1e-12)
    # our P went through the quaternion normalisation's Jacobian too; undo nothing, compare
    # the blocks it does not touch
    np.testing.assert_allclose(f.P[7:, 7:], kf.P[7:, 7:], rtol=1e-7, atol=1e-12)
    assert not np.allclose(P_before, f.P)


def test_prediction_matches_unscented_transform():
    """EKF ``F P F^T + G Q_n G^T`` against the unscented transform of the transcribed eq. 3
    on the state augmented with its noise (filterpy's sigma points)."""
    dt = 1 / 30
    x = mm.initial_state(p=[0, 0, -2.5], q=synth.quat.normalize([1, 0.1, -0.2, 0.05]),
                         v=[0.5, 0.1, -0.2], w=[0.3, -0.5, 0.2], a=[1.0, -0.5, 0.3])
    P = np.diag(np.r_[np.full(3, 1e-4), np.full(4, 1e-8), np.full(3, 1e-3), np.full(3, 1e-3),
                      np.full(3, 1e-2), np.full(3, 1e-4)])
    noise = mm.MotionNoise()
    x_new, F, G = mm.predict(x, dt)
    P_ekf = F @ P @ F.T + mm.process_noise(G, noise)
    xa = np.r_[x, np.zeros(9)]
    Pa = np.zeros((28, 28))
    Pa[:19, :19], Pa[19:, 19:] = P, noise.covariance()
    pts = MerweScaledSigmaPoints(28, alpha=1e-2, beta=2.0, kappa=0.0)
    sig = pts.sigma_points(xa, Pa)
    out = np.array([sugiyama_eq3(s[:19], s[19:], dt) for s in sig])
    m_ut, P_ut = unscented_transform(out, pts.Wm, pts.Wc)
    # the quaternion's sigma-point mean is shorter by ~E[|θ|^2]/8 (unit vectors averaged)
    np.testing.assert_allclose(m_ut[3:7], x_new[3:7], atol=5e-5)
    np.testing.assert_allclose(np.delete(m_ut, np.s_[3:7]), np.delete(x_new, np.s_[3:7]),
                               atol=1e-6)
    sd = np.sqrt(np.diag(P_ekf))
    np.testing.assert_allclose(P_ut / np.outer(sd, sd), P_ekf / np.outer(sd, sd), atol=2e-3)


def test_nees_with_known_features_is_consistent():
    """With every feature known, the pose NEES averaged over runs and time sits in the band
    (measured 3.1 for 3 dof)."""
    rng = np.random.default_rng(100)
    known = np.vstack([synth.SCREEN, synth.world_points(rng, 300)])
    values = []
    orig = synth.SCREEN
    try:
        synth.SCREEN = known
        for seed in range(4):
            r = synth.run(seed=seed, duration=1.5, n_target=0)
            values.append(nees(r.est[:, 0:3] - r.truth[:, 0:3], r.cov[:, 0:3, 0:3])[20:])
            assert rmse(r.est[:, 0:3] - r.truth[:, 0:3]) < 0.015  # measured ~5 mm
    finally:
        synth.SCREEN = orig
    mean = float(np.mean(values))
    lo, hi = chi2_band(3, 4 * 20)  # ~20 independent stretches per run (correlated samples)
    assert lo < mean < hi, (mean, lo, hi)


def test_slam_with_inverse_depth_features():
    """Monocular SLAM with new features: the pose stays within centimetres of the truth and
    the filter is at most mildly overconfident (EKF SLAM's known inconsistency, Huang et al.
    2010; measured mean pose NEES 4.5 for 3 dof over 8 seeds)."""
    errs, nees_means = [], []
    for seed in range(3):
        r = synth.run(seed=seed, duration=2.0)
        e = r.est[:, 0:3] - r.truth[:, 0:3]
        errs.append(rmse(e))
        nees_means.append(np.mean(nees(e, r.cov[:, 0:3, 0:3])[20:]))
        assert np.all(np.isfinite(r.est))
    assert max(errs) < 0.1, errs  # measured 0.010-0.037 m
    assert np.mean(nees_means) < 12.0, nees_means  # measured 4.9


def test_conversion_preserves_mean_and_covariance():
    rng = np.random.default_rng(4)
    f = _filter_with_map(rng)
    before_ids, before_pts, before_cov = f.feature_points()
    P_before = f.P.copy()
    converted = f.convert_linear(threshold=np.inf)  # convert every inverse-depth feature
    assert len(converted) == 3 and all(ft.dim == 3 for ft in f.features)
    ids, pts, cov = f.feature_points()
    np.testing.assert_array_equal(ids, before_ids)
    np.testing.assert_allclose(pts, before_pts, atol=1e-12)
    np.testing.assert_allclose(cov, before_cov, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(f.P[:19, :19], P_before[:19, :19])
    assert len(f.x) == 19 + 7 * 3


def test_delete_removes_rows_and_columns():
    rng = np.random.default_rng(5)
    f = _filter_with_map(rng)
    ids = [ft.fid for ft in f.features]
    keep = f.feature(ids[5])
    y_keep = f.x[keep.offset:keep.offset + keep.dim].copy()
    f.delete([ids[4]])
    assert len(f.x) == 19 + 4 * 3 + 2 * 6 and f.P.shape == (len(f.x),) * 2
    assert f.feature(ids[5]).offset == 19 + 12
    np.testing.assert_array_equal(f.x[31:37], y_keep)
    with pytest.raises(KeyError):
        f.feature(ids[4])


def test_camera_only_and_imu_only_stay_finite():
    for kw in (dict(use_imu=False), dict(use_camera=False)):
        r = synth.run(seed=1, duration=1.0, **kw)
        assert np.all(np.isfinite(r.est)) and np.all(np.isfinite(r.cov))
    cam = synth.run(seed=1, duration=1.0, use_imu=False)
    imu = synth.run(seed=1, duration=1.0, use_camera=False)
    fused = synth.run(seed=1, duration=1.0)
    e = {k: rmse(r.est[:, 0:3] - r.truth[:, 0:3]) for k, r in
         (("camera", cam), ("imu", imu), ("fused", fused))}
    assert e["fused"] < e["imu"], e
    # measured 6.6, 8.8, 98 mm (2026-11-29): monocular alone has no scale, the IMU alone drifts
    assert e["fused"] < 0.015 and e["camera"] > 3 * e["fused"], e


def test_gain_update_rejects_indefinite_innovation():
    x, P = np.zeros(3), np.eye(3)
    with pytest.raises(np.linalg.LinAlgError):
        up.gain_update(x, P, np.eye(3)[:, :2], -np.eye(2), np.ones(2))


def test_compressed_imu_steps_equal_the_dense_filter():
    """Six IMU steps on the interface block with the map's share deferred (Guivant & Nebot)
    give the dense EKF's mean and covariance (filterpy, full-size F and H) exactly."""
    rng = np.random.default_rng(6)
    f = _filter_with_map(rng)
    n = len(f.x)
    kf = KalmanFilter(dim_x=n, dim_z=10)
    kf.x, kf.P = f.x.copy(), f.P.copy()
    t = 0.0
    for _ in range(6):
        t += 1 / 180
        x_new, F, G = mm.predict(kf.x[:19], 1 / 180)
        F_full = np.eye(n)
        F_full[:19, :19] = F
        Q_full = np.zeros((n, n))
        Q_full[:19, :19] = mm.process_noise(G, f.params.noise)
        kf.predict(F=F_full, Q=Q_full)
        kf.x[:19] = x_new  # the nonlinear mean, as the EKF
        q = synth.quat.normalize(x_new[3:7] + 1e-3 * rng.standard_normal(4))
        a, w = rng.standard_normal(3), rng.standard_normal(3)
        H = np.zeros((10, n))
        H[0:4, 3:7] = np.eye(4)
        H[4:7, 13:16] = H[4:7, 16:19] = np.eye(3)
        H[7:10, 10:13] = np.eye(3)
        R = np.diag(np.r_[np.full(4, 1e-6), np.full(3, 0.25), np.full(3, 1e-4)])
        kf.update(np.r_[q, a, w], R=R, H=H)
        f.predict(t)
        f.update_inertial(q, a, w)
        # the filter renormalises q: do the same to the reference
        J = np.eye(n)
        J[3:7, 3:7] = synth.quat_jac.d_normalize(kf.x[3:7])
        kf.x[3:7] /= np.linalg.norm(kf.x[3:7])
        kf.P = J @ kf.P @ J.T
    np.testing.assert_allclose(f.x, kf.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(f.P, kf.P, rtol=1e-7, atol=1e-12)


def test_map_update_after_imu_steps_equals_the_dense_filter():
    """IMU steps, then a feature update (which renormalises q over the whole state), then
    more IMU steps: still the dense EKF's numbers (the covariance stays positive)."""
    rng = np.random.default_rng(7)
    f = _filter_with_map(rng)
    g = _filter_with_map(np.random.default_rng(7))
    for k in range(1, 4):
        for filt, flush in ((f, False), (g, True)):
            filt.predict(k / 90)
            filt.update_inertial(filt.interface[3:7].copy(), np.ones(3), None)
            if flush:
                _ = filt.P  # the reference applies every step to the map at once
        for filt in (f, g):
            pred = filt.predict_features()
            filt.update_features(pred, np.arange(len(pred.fids)), pred.uv + 0.5)
    np.testing.assert_allclose(f.x, g.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(f.P, g.P, rtol=1e-7, atol=1e-12)
    assert np.linalg.eigvalsh(f.P).min() > -1e-12


def test_state_blocks_convert_is_the_dense_jacobian_product():
    """``state_blocks.convert`` equals ``J P J^T`` with the dense block-diagonal Jacobian."""
    from humimic.estimation.ekf import state_blocks as sb

    rng = np.random.default_rng(8)
    n = 19 + 6 + 3 + 6
    x, P = rng.standard_normal(n), _random_cov(rng, n)
    src = np.array([np.arange(19, 25), np.arange(28, 34)])  # two 6-blocks become 3-blocks
    J = rng.standard_normal((2, 3, 6))
    values = rng.standard_normal((2, 3))
    dst = np.array([np.arange(19, 22), np.arange(25, 28)])
    old = np.r_[np.arange(19), np.arange(25, 28)]
    new = np.r_[np.arange(19), np.arange(22, 25)]
    x_new, P_new = sb.convert(x, P, old, new, src, dst, values, J)
    T = np.zeros((28, n))
    T[new, old] = 1.0
    for i in range(2):
        T[np.ix_(dst[i], src[i])] = J[i]
    np.testing.assert_allclose(P_new, T @ P @ T.T, atol=1e-12)
    np.testing.assert_allclose(x_new[new], x[old])
    np.testing.assert_allclose(x_new[dst.ravel()], values.ravel())
