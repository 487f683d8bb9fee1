"""Stereo 3-D (Ude eq. 10): DLT vs OpenCV, Jacobian vs finite differences, covariance vs Monte
Carlo (Ude Table 2), and ZNCC epipolar matching on rendered, non-rectified, distorted views."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from _synth_vision import TexturedPlane, point_on_plane_seen_at, stereo_head

from humimic.perception.blobs.stereo import (
    StereoRig,
    dlt_jacobian,
    match_and_triangulate,
    triangulate_dlt,
)

COV_UV = np.array([[0.65, -0.02], [-0.02, 0.67]])  # Ude Table 2, px^2


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(0)
    cam_l, cam_r = stereo_head()
    e2 = np.array([0.2, 0.0, -1.0]) / np.linalg.norm([0.2, 0.0, -1.0])
    plane = TexturedPlane(rng, origin=(1.0, 0.0, 1.2), e1=(0, -1, 0), e2=e2)
    return cam_l, cam_r, plane, plane.render(cam_l), plane.render(cam_r)


def test_dlt_matches_opencv_triangulate_points():
    rng = np.random.default_rng(1)
    cam_l, cam_r = stereo_head()
    rig = StereoRig(cam_l, cam_r)
    X = np.array([1.0, 0.0, 1.2]) + rng.normal(scale=[0.3, 0.3, 0.2], size=(50, 3))
    x1 = cam_l.intrinsics.undistort_normalized(cam_l.project_base(X))
    x2 = cam_r.intrinsics.undistort_normalized(cam_r.project_base(X))
    x1 = x1 + rng.normal(scale=2e-3, size=x1.shape)  # inconsistent (noisy) correspondences
    x2 = x2 + rng.normal(scale=2e-3, size=x2.shape)
    X_h, _ = triangulate_dlt(rig.P_left, rig.P_right, x1, x2)
    ours = X_h[:, :3] / X_h[:, 3:]
    ref = cv2.triangulatePoints(rig.P_left, rig.P_right, x1.T.copy(), x2.T.copy())
    np.testing.assert_allclose(ours, (ref[:3] / ref[3]).T, rtol=1e-9, atol=1e-12)


def test_triangulate_recovers_exact_points_through_distortion():
    rng = np.random.default_rng(2)
    cam_l, cam_r = stereo_head(k1=-0.12, k2=0.03)
    X = np.array([1.0, 0.0, 1.2]) + rng.normal(scale=0.2, size=(20, 3))
    p, _ = StereoRig(cam_l, cam_r).triangulate(cam_l.project_base(X), cam_r.project_base(X))
    np.testing.assert_allclose(p, X, atol=1e-9)


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(3)
    cam_l, cam_r = stereo_head()
    rig = StereoRig(cam_l, cam_r)
    x1, x2 = np.array([[0.05, -0.02]]), np.array([[0.11, -0.01]])
    X_h, svd = triangulate_dlt(rig.P_left, rig.P_right, x1, x2)
    J = dlt_jacobian(rig.P_left, rig.P_right, X_h, svd)[0]
    h = 1e-7
    for i in range(4):
        d = np.zeros(4)
        d[i] = h
        Xp, _ = triangulate_dlt(rig.P_left, rig.P_right, x1 + d[:2], x2 + d[2:])
        Xm, _ = triangulate_dlt(rig.P_left, rig.P_right, x1 - d[:2], x2 - d[2:])
        fd = (Xp[0, :3] / Xp[0, 3] - Xm[0, :3] / Xm[0, 3]) / (2 * h)
        np.testing.assert_allclose(J[:, i], fd, rtol=1e-5, atol=1e-6 * np.abs(J).max())
    intr = cam_l.intrinsics
    x, y = 0.3 * rng.random(2)
    Ju = intr.undistort_jacobian(np.array([x, y]))
    uv0 = intr.project(np.array([x, y, 1.0]))
    for i in range(2):
        e = np.zeros(2)
        e[i] = 1e-4
        fd = intr.undistort_normalized(uv0 + e) - intr.undistort_normalized(uv0 - e)
        np.testing.assert_allclose(Ju[:, i], fd / 2e-4, rtol=1e-6)


def test_propagated_covariance_matches_monte_carlo():
    """Ude Table 2: covariance propagation vs the empirical covariance of noisy triangulation."""
    cam_l, cam_r = stereo_head()
    rig = StereoRig(cam_l, cam_r)
    X = np.array([1.0, 0.1, 1.1])  # a hand at about 1 m
    uv_l, uv_r = cam_l.project_base(X), cam_r.project_base(X)
    cov_r = np.array([[0.66, -0.012], [-0.012, 0.67]])
    _, R = rig.triangulate(uv_l, uv_r, COV_UV, cov_r)
    rng = np.random.default_rng(4)
    n = 20000
    nl = rng.multivariate_normal(np.zeros(2), COV_UV, size=n)
    nr = rng.multivariate_normal(np.zeros(2), cov_r, size=n)
    P, _ = rig.triangulate(uv_l + nl, uv_r + nr)
    emp = np.cov(P.T)
    # Measured: first-order propagation is 3-4 % below the empirical variances (depth ~ 1/d is
    # convex, a second-order effect at d ~ 18 px, sigma_d ~ 1.1 px); sampling error ~1 %.
    np.testing.assert_allclose(np.diag(R), np.diag(emp), rtol=0.08)
    assert np.linalg.norm(R - emp) / np.linalg.norm(emp) < 0.08
    assert np.sqrt(R[0, 0]) > 5 * np.sqrt(R[2, 2])  # depth (base x) dominates, as in the paper


def test_match_on_rendered_plane(scene):
    cam_l, cam_r, plane, img_l, img_r = scene
    rig = StereoRig(cam_l, cam_r)
    uv_l = np.array([[160.0, 120.0], [100.2, 80.7], [220.5, 170.1], [60.0, 200.0]])
    X = np.array([point_on_plane_seen_at(plane, cam_l, u) for u in uv_l])
    uv_r_true = cam_r.project_base(X)
    blob_r = uv_r_true + np.array([3.0, -2.0])  # right blob centres are only roughly right
    blob_cov = np.repeat(4.0 * np.eye(2)[None], 4, 0)  # small blobs: 1-px template spacing
    ms = rig.match_many(img_l, img_r, uv_l, blob_cov, blob_r, 16 * blob_cov, COV_UV, COV_UV)
    for m, Xi, ur in zip(ms, X, uv_r_true, strict=True):
        assert m.ok, m.reason
        assert m.score > 0.75  # measured 0.85-0.96 (foreshortened plane, image corner)
        # measured: <= 0.05 px along the epipolar line, <= 3.2 mm at ~1 m
        assert np.linalg.norm(m.uv_right - ur) < 0.15
        assert np.linalg.norm(m.p_base - Xi) < 0.006
        assert np.all(np.isfinite(m.R_base)) and np.all(np.linalg.eigvalsh(m.R_base) > 0)
    one = match_and_triangulate(img_l, img_r, cam_l, cam_r, uv_l[0], blob_cov[0], blob_r[0],
                                64 * np.eye(2), COV_UV, COV_UV)
    np.testing.assert_allclose(one.p_base, ms[0].p_base, atol=1e-12)


def test_failures_are_flagged_not_nan(scene):
    cam_l, cam_r, plane, img_l, img_r = scene
    rig = StereoRig(cam_l, cam_r)
    X = point_on_plane_seen_at(plane, cam_l, (160.0, 120.0))
    ur = cam_r.project_base(X)
    cases = {
        "epipolar_line_misses_right_blob": (img_l, img_r, (160.0, 120.0), ur + [0, 60]),
        "template_out_of_image": (img_l, img_r, (2.0, 120.0), ur),
        "non_finite_input": (img_l, img_r, (np.nan, 120.0), ur),
        "low_zncc": (np.zeros_like(img_l), np.zeros_like(img_r), (160.0, 120.0), ur),
    }
    for reason, (il, ir, ul, ub) in cases.items():
        m = rig.match(il, ir, np.array(ul), 4 * np.eye(2), np.array(ub), 64 * np.eye(2), COV_UV,
                      COV_UV)
        assert not m.ok and m.reason == reason
        for a in (m.p_base, m.R_base, m.uv_left, m.uv_right, m.score):
            assert np.all(np.isfinite(a))


def test_following_covariance_matches_monte_carlo():
    """The template follows the left centre: a centre error e moves the right match by e, and
    the match adds its own error along the epipolar line. Propagation vs sampling that model."""
    from humimic.perception.blobs.stereo import following_covariance

    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    rig = StereoRig(cam_l, cam_r)
    X = np.array([1.0, 0.1, 1.1])
    uv_l, uv_r = cam_l.project_base(X), cam_r.project_base(X)
    ray = (X - cam_l.T_base_cam[:3, 3]) / np.linalg.norm(X - cam_l.T_base_cam[:3, 3])
    t = cam_r.project_base(X + 1e-3 * ray) - uv_r
    t /= np.linalg.norm(t)
    C_l, s_m = np.array([[0.06, -0.02], [-0.02, 0.1]]), 0.05
    _, R = rig.triangulate(uv_l, uv_r, cov_joint=following_covariance(C_l, s_m, t[None])[0])
    rng = np.random.default_rng(5)
    e = rng.multivariate_normal(np.zeros(2), C_l, size=20000)
    m = rng.normal(0.0, s_m, size=(20000, 1)) * t
    P, _ = rig.triangulate(uv_l + e, uv_r + e + m)
    emp = np.cov(P.T)
    np.testing.assert_allclose(np.diag(R), np.diag(emp), rtol=0.05)
    _, R_ind = rig.triangulate(uv_l, uv_r, C_l, C_l + s_m**2 * np.outer(t, t))
    assert R_ind[0, 0] > 20 * emp[0, 0]  # independent points: depth overstated (measured 50x)


def test_colour_masked_match_ignores_background_clutter():
    """A uniformly coloured disc 1 m away over a textured wall 3 m away: the plain box template
    holds wall texture that sits at another disparity; the colour-masked match sees the disc
    (its outline) only."""
    from _synth_vision import SKIN_RGB, add_noise, draw_ellipse

    from humimic.perception.cues.color_models import ColorLUT, fit_color_model

    rng = np.random.default_rng(6)
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    wall = TexturedPlane(rng, origin=(3.0, 0.0, 1.2), e1=(0, -1, 0), e2=(0, 0, -1),
                         size_m=4.0, tex_px=800)
    patch = add_noise(np.full((40, 40, 3), SKIN_RGB, np.uint8), rng, 3.0)
    lut = ColorLUT(fit_color_model(patch.reshape(-1, 3), "rgb", 1, np.random.default_rng(1)))
    rig = StereoRig(cam_l, cam_r)
    errs = {"plain": [], "masked": []}
    for k in range(8):
        X = np.array([1.0, -0.1 + 0.03 * k, 1.15])  # the disc's centre (a flat disc)
        img_l, img_r = wall.render(cam_l), wall.render(cam_r)
        uv_l, uv_r = cam_l.project_base(X), cam_r.project_base(X)
        draw_ellipse(img_l, uv_l, (7, 7), 0)
        draw_ellipse(img_r, uv_r, (7, 7), 0)
        img_l, img_r = add_noise(img_l, rng, 2.0), add_noise(img_r, rng, 2.0)
        cov = 12.0 * np.eye(2)
        for key, luts in (("plain", None), ("masked", [lut])):
            m = rig.match(img_l, img_r, uv_l, cov, uv_r, cov, COV_UV, COV_UV,
                          None if luts is None else luts[0])
            errs[key].append(np.linalg.norm(m.p_base - X) if m.ok else np.inf)
    masked, plain = np.array(errs["masked"]), np.array(errs["plain"])
    assert masked.max() < 0.012  # measured <= 6.6 mm at 1 m (disparity ~14 px)
    assert plain.max() > 2 * masked.max()  # measured: plain up to 23 mm


class _SpeckledLUT:
    """A skin table with holes: a disc pixel counts as skin unless its noisy red level is a
    multiple of 8 (an eighth of them, drawn by each eye's own pixel noise), as a table cut in
    the bins a skin-like shirt shares leaves the skin; the grey background is never skin."""

    @staticmethod
    def lookup(rgb):
        r = np.asarray(rgb)[..., 0].astype(int)
        return np.where((r > 140) & (r % 8 != 0), 1e3, 0.0).astype(np.float32)

    def posterior(self, rgb):
        p = self.lookup(rgb)
        return p / (p + 1.0)


def test_closed_mask_matches_a_speckled_blob():
    """The colour mask of a blob whose pixels the table drops at random, differently in each
    eye (pixel noise across a cut bin's edge): the per-pixel mask makes the template match the
    speckle; closed (``mask_closing``, the default 1 px) it matches the blob's outline."""
    from _synth_vision import add_noise, draw_ellipse

    from humimic.perception.blobs.stereo import StereoParams

    rng = np.random.default_rng(11)
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    lut = _SpeckledLUT()
    errs: dict[int, list[float]] = {0: [], 1: []}
    for k in range(24):
        X = np.array([1.2, -0.12 + 0.01 * k, 1.15])
        img_l, img_r = (np.full((240, 320, 3), 110, np.uint8) for _ in range(2))
        uv_l, uv_r = cam_l.project_base(X), cam_r.project_base(X)
        for img, uv in ((img_l, uv_l), (img_r, uv_r)):
            draw_ellipse(img, uv, (6, 6), 0, (200, 150, 120))
        img_l, img_r = add_noise(img_l, rng, 2.0), add_noise(img_r, rng, 2.0)
        cov = 9.0 * np.eye(2)
        for closing in errs:
            rig = StereoRig(cam_l, cam_r, StereoParams(mask_closing=closing))
            m = rig.match(img_l, img_r, uv_l, cov, uv_r, cov, COV_UV, COV_UV, lut)
            errs[closing].append(np.linalg.norm(m.p_base - X) if m.ok else np.inf)
    closed, speckled = np.array(errs[1]), np.array(errs[0])
    assert StereoParams().mask_closing == 1
    # measured (seeds 11-14): RMS 6.1-9.4 mm closed, 12.4-18.7 mm per-pixel (ratio 0.50-0.58)
    assert np.sqrt(np.mean(closed**2)) < 0.75 * np.sqrt(np.mean(speckled**2))
    assert np.sqrt(np.mean(closed**2)) < 0.02


def test_small_blob_scale_against_eigenvalues():
    """max(1, ref / max(sigma_blob, floor)), sigma_blob the mean of the shape's two standard
    deviations (numpy's eigenvalues): blobs at least ``ref`` wide keep the calibrated noise,
    blobs under the floor grow it no further."""
    from humimic.perception.blobs.triangulation import small_blob_scale

    rng = np.random.default_rng(4)
    A = rng.normal(size=(50, 2, 2)) * rng.uniform(0.5, 8, (50, 1, 1))
    covs = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(2)
    sig = np.sqrt(np.linalg.eigvalsh(covs)).mean(1)
    np.testing.assert_allclose(small_blob_scale(covs, 5.0, 0.1),
                               np.maximum(1.0, 5.0 / np.maximum(sig, 0.1)), rtol=1e-9)
    np.testing.assert_allclose(small_blob_scale(covs, 5.0),
                               np.maximum(1.0, 5.0 / np.maximum(sig, 2.5)), rtol=1e-9)
    assert np.all(small_blob_scale(covs, None) == 1.0)
    assert small_blob_scale(np.diag([9.0, 4.0]), 5.0)[0] == pytest.approx(2.0)  # sigma 2.5
    assert small_blob_scale(np.diag([4.0, 1.0]), 5.0)[0] == pytest.approx(2.0)  # floored
    assert small_blob_scale(np.diag([4.0, 1.0]), 5.0, 1.0)[0] == pytest.approx(5.0 / 1.5)
    assert small_blob_scale(np.diag([49.0, 36.0]), 5.0)[0] == 1.0


def test_following_covariance_takes_a_match_noise_per_target():
    from humimic.perception.blobs.triangulation import following_covariance

    t = np.array([[1.0, 0.0], [0.6, 0.8]])
    Cl = np.eye(2) * 0.09
    both = following_covariance(Cl, np.array([0.04, 0.1]), t)
    for r, s in enumerate((0.04, 0.1)):
        np.testing.assert_array_equal(both[r], following_covariance(Cl, s, t[r:r + 1])[0])


def test_core_grows_the_noise_of_small_blobs(monkeypatch):
    """PerceptionCore hands the stereo stage pixel_std and match_std grown by
    small_blob_scale of each target's left blob (the farther, smaller blob: a larger R)."""
    from test_perception_locks import Scripted

    from humimic.perception.blobs.triangulation import small_blob_scale

    calls = []

    def spy(self, il, ir, uv_l, cov_l, uv_r, cov_r, C_l, C_r, luts=None, match_std=None):
        calls.append((np.array(cov_l), np.array(C_l), np.array(match_std)))
        return [type("M", (), {"ok": False, "reason": "spy", "score": 0.0})()] * len(uv_l)

    monkeypatch.setattr(StereoRig, "match_many", spy)
    s = Scripted(pixel_std=0.3, match_std=0.05)
    s.frames(12)
    assert calls
    cov_l, C_l, ms = calls[-1]
    k = small_blob_scale(cov_l, 5.0)
    assert np.any(k > 1.0)  # the synthetic blobs include ones under 5 px
    np.testing.assert_allclose(C_l, 0.09 * k[:, None, None] ** 2 * np.eye(2))
    np.testing.assert_allclose(ms, 0.05 * k)
