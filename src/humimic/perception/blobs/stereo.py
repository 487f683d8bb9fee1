"""Stereo 3-D blob positions (Ude eq. 10) and their covariances, cameras in arbitrary poses.

The eyes pan and tilt, so the images are never assumed rectified. For each target:

1. The left blob centre is undistorted to the ideal (distortion-free) left image; its ray's image
   in the ideal right image is a straight line (the epipolar line): from the vanishing point of
   the ray, direction ``a_xy b_z - a_z b_xy`` (``a`` the left camera centre and ``b`` the ray
   direction in right-camera coordinates), parameterised by ideal-pixel arc length ``s``.
2. The search interval of ``s`` is where that line crosses the right blob's box (centre +-
   ``box_sigma`` sigma, in ideal pixels) and the depth range ``[z_min, z_max]``.
3. Local rectification: a strip along the line (rows along its normal) and a box template around
   the left point (columns along the left epipolar direction) are sampled on ideal-pixel grids,
   distorted to raw pixels and read with ``cv2.remap`` (bilinear) from images blurred by
   ``prefilter_sigma`` (anti-aliasing: the rendered edges are hard steps). Both grids are
   oriented by the image of the baseline direction and share a spacing ``d`` scaled to the left
   blob's size (so the template holds the blob's outline), so the search is 1-D: ZNCC (eq. 10,
   colour) at every sample of ``s``. Optionally (``template_luts``) both images are first
   colour-masked (each pixel times its probability of having the target's colour), so the
   background around the blob, at another depth and shifted differently, turns black and only
   the blob (its outline and shading) is matched.
4. Sub-pixel: the template is correlated again at ``d / fine_steps`` offsets within +-d of the
   best sample; a parabola through the best three gives the match, exactly on the line.
5. Homogeneous linear triangulation (DLT, as ``cv2.triangulatePoints``) of the undistorted
   normalised points with ``P = T_cam_base[:3]``: the base-frame point
   (:mod:`humimic.perception.blobs.triangulation`).
6. ``R = J C J^T``, ``J`` the analytic Jacobian of step 5 (first-order perturbation of the DLT
   null vector) chained with the Jacobians of undistortion; ``C`` the 4x4 pixel covariance of
   the correspondence: ``diag(C_left, C_right)`` (Ude's Table 2) or, since the right match
   follows the template cut at the left centre, :func:`following_covariance`.

All targets of a frame go through one batch (:meth:`StereoRig.match_many`): the array work does
not grow with the number of targets, only the small per-target scalar set-up does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from humimic.perception.blobs.occlusion import target_fraction, window_mass_px
from humimic.perception.blobs.triangulation import (  # noqa: F401  (re-exported)
    dlt_jacobian,
    following_covariance,
    joint_covariance,
    small_blob_scale,
    triangulate_dlt,
)
from humimic.perception.blobs.zncc import Prefiltered, zncc_strips, zncc_windows
from humimic.perception.blobs.zncc import read_batch as _read
from humimic.sensors.camera_model import CameraModel, invert_transform


@dataclass(frozen=True)
class StereoParams:
    template_half: int = 8
    """The template has (2 half + 1)^2 samples."""
    template_sigma: float = 1.5
    """The template spans +- this many of the left blob's largest standard deviation (so that it
    holds the blob's outline: a template inside a uniformly coloured blob is flat), sampled at
    a spacing of max(1 px, that span / half); the strip is sampled at the same spacing."""
    max_spacing_px: float = 12.0
    box_sigma: float = 1.5
    """Right search box: right blob centre +- box_sigma * sqrt(diag(blob_cov_right))."""
    z_min: float = 0.1
    z_max: float = 20.0
    """Depth range (m, along the left ray) of the epipolar search."""
    min_zncc: float = 0.5
    """ZNCC below this fails with reason 'low_zncc'."""
    prefilter_sigma: float = 0.8
    """Least Gaussian blur (px) of the images before they are sampled, growing to half the
    sample spacing for big blobs (:class:`~humimic.perception.blobs.zncc.Prefiltered`, on the crops
    the samples need): anti-aliasing, so a template shifted by a fraction of a pixel still
    matches at the shifted place (rendered edges are hard steps; bilinear reads of them are not
    shift-invariant). 0: no prefilter."""
    fine_steps: int = 4
    """After the search at the template's sample spacing d, the template is correlated at
    offsets of d / fine_steps within +-d of the best sample and a parabola through the best
    three gives the sub-pixel match (a parabola on the coarse samples alone is biased towards
    them: 'pixel locking')."""
    mask_closing: int = 1
    """With colour masks, the probability image is closed by a square of this half-width (px)
    before it multiplies the image (:func:`~humimic.perception.blobs.zncc.closed_posterior`):
    holes the pixel noise punched into a blob's mask (a shirt of nearly its colour) are filled
    in both eyes alike. 0: the plain per-pixel mask."""
    min_target_fraction: float = 0.1
    """With colour masks (``template_luts``), a template less target-coloured than this (mean
    probability) fails with reason 'few_target_pixels'."""
    occlusion_check: bool = True
    occlusion_window_s: float = 0.2
    occlusion_min_drop: float = 0.2
    occlusion_spread_k: float = 3.0
    occlusion_min_asymmetry: float = 0.05
    """The core's 'shrinking_blob' refusal (:mod:`~humimic.perception.blobs.occlusion`)."""


@dataclass(frozen=True)
class StereoMeasurement:
    ok: bool
    reason: str
    """'' when ok, else why not. Never NaN: failures carry zeros."""
    p_base: np.ndarray
    """Triangulated point (m), base frame."""
    R_base: np.ndarray
    """3x3 covariance of p_base (m^2), base frame."""
    uv_left: np.ndarray
    uv_right: np.ndarray
    """The match in raw right-image pixels."""
    score: float
    mass_px: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """Target pixels of the left template and of the matched right window (colour masks only,
    the right one with ``occlusion_check``; zeros without, and on failures):
    :mod:`~humimic.perception.blobs.occlusion`."""


def _fail(reason: str, uv_left, score: float = 0.0) -> StereoMeasurement:
    return StereoMeasurement(False, reason, np.zeros(3), np.zeros((3, 3)),
                             np.nan_to_num(np.asarray(uv_left, float)), np.zeros(2), score)


class StereoRig:
    """A left/right camera pair at one instant (the eyes' current pose) and the matcher."""

    def __init__(self, cam_left: CameraModel, cam_right: CameraModel,
                 params: StereoParams = StereoParams()) -> None:
        self.intr_l, self.intr_r = cam_left.intrinsics, cam_right.intrinsics
        self.T_base_left, self.T_base_right = cam_left.T_base_cam, cam_right.T_base_cam
        self.P_left = invert_transform(cam_left.T_base_cam)[:3]
        self.P_right = invert_transform(cam_right.T_base_cam)[:3]
        self.params = params
        b_base = cam_right.T_base_cam[:3, 3] - cam_left.T_base_cam[:3, 3]
        self._b_left = cam_left.T_base_cam[:3, :3].T @ b_base  # baseline, left-camera axes
        self._R_rl = self.P_right[:, :3] @ cam_left.T_base_cam[:3, :3]  # left -> right axes
        self._a = self.P_right @ np.append(cam_left.T_base_cam[:3, 3], 1.0)  # c_left, right axes
        self._b_right = self.P_right[:, :3] @ b_base
        self._k = np.arange(-params.template_half, params.template_half + 1, dtype=float)

    def triangulate(self, uv_left: np.ndarray, uv_right: np.ndarray,
                    cov_left: np.ndarray | None = None, cov_right: np.ndarray | None = None,
                    cov_joint: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Base-frame points ``(N, 3)`` (m) and covariances ``(N, 3, 3)`` from raw pixels.

        ``uv_*`` are ``(N, 2)`` (or ``(2,)`` for one point: results are then unbatched); pixel
        covariances (2x2, or ``(N, 2, 2)``) default to zero and are independent, unless the
        joint covariance of ``(u_l, v_l, u_r, v_r)`` is given (``cov_joint``, 4x4 or
        ``(N, 4, 4)``, e.g. :func:`following_covariance`).
        """
        single = np.ndim(uv_left) == 1
        uvl, uvr = np.atleast_2d(uv_left), np.atleast_2d(uv_right)
        xl = self.intr_l.undistort_normalized(np.asarray(uvl, float))
        xr = self.intr_r.undistort_normalized(np.asarray(uvr, float))
        p, R = self._triangulate_normalised(xl, xr, joint_covariance(len(xl), cov_left, cov_right,
                                                           cov_joint))
        return (p[0], R[0]) if single else (p, R)

    def _triangulate_normalised(self, xl, xr, C):
        """Points and covariances from normalised points and the (N, 4, 4) pixel covariance."""
        X_h, svd = triangulate_dlt(self.P_left, self.P_right, xl, xr)
        p_base = X_h[:, :3] / X_h[:, 3:]
        J = dlt_jacobian(self.P_left, self.P_right, X_h, svd)  # (N, 3, 4)
        Ju = np.zeros((len(xl), 4, 4))
        Ju[:, 0:2, 0:2] = self.intr_l.undistort_jacobian(xl)
        Ju[:, 2:4, 2:4] = self.intr_r.undistort_jacobian(xr)
        Jt = J @ Ju
        return p_base, Jt @ C @ np.swapaxes(Jt, 1, 2)

    def _epipolar_interval(self, xl, yl, cu, cv, hu, hv):
        """Ideal-right-pixel line ``q(s) = q0 + s t`` for a left point, its search interval and
        the in-plane 'baseline' direction at the left point; None if the interval is empty."""
        p, ir = self.params, self.intr_r
        bx, by, bz = (self._R_rl @ np.array([xl, yl, 1.0])).tolist()  # ray direction, right
        ax, ay, az = self._a.tolist()
        if bz <= 1e-9:
            return None
        dx, dy = ax * bz - az * bx, ay * bz - az * by  # normalised: x(z) = v + dlt/(bz(az+z bz))
        tx, ty = ir.fx * dx, ir.fy * dy  # the same in ideal pixels
        norm = math.hypot(tx, ty)
        if norm < 1e-12:
            return None
        q0 = (ir.fx * bx / bz + ir.cx, ir.fy * by / bz + ir.cy)  # vanishing point (z -> inf)
        # s(z) = norm / (bz (az + z bz)): decreasing in z; points in front need az + z bz > 0
        s_lo = norm / (bz * (az + p.z_max * bz)) if az + p.z_max * bz > 0 else math.inf
        s_hi = norm / (bz * (az + p.z_min * bz)) if az + p.z_min * bz > 0 else math.inf
        tx, ty = tx / norm, ty / norm
        for q, t, c, h in ((q0[0], tx, cu, hu), (q0[1], ty, cv, hv)):  # slab clipping
            if abs(t) < 1e-12:
                if abs(q - c) > h:
                    return None
                continue
            s1, s2 = sorted(((c - h - q) / t, (c + h - q) / t))
            s_lo, s_hi = max(s_lo, s1), min(s_hi, s2)
        if not s_hi - s_lo >= 2.0:
            return None
        # orientation: the image of moving along the baseline (as for the left template)
        xm = (q0[0] + 0.5 * (s_lo + s_hi) * tx - ir.cx) / ir.fx
        ym = (q0[1] + 0.5 * (s_lo + s_hi) * ty - ir.cy) / ir.fy
        brx, bry, brz = self._b_right.tolist()
        sign = 1.0 if tx * ir.fx * (brx - xm * brz) + ty * ir.fy * (bry - ym * brz) >= 0 else -1.0
        blx, bly, blz = self._b_left.tolist()
        il = self.intr_l
        lx, ly = il.fx * (blx - xl * blz), il.fy * (bly - yl * blz)
        ln = math.hypot(lx, ly)
        if ln < 1e-12:
            return None
        return q0, (sign * tx, sign * ty), (s_lo, s_hi) if sign > 0 else (-s_hi, -s_lo), \
            (lx / ln, ly / ln)

    def match_many(self, image_left: np.ndarray, image_right: np.ndarray, uv_left,
                   blob_cov_left, uv_right_blob, blob_cov_right, cov_uv_left, cov_uv_right,
                   template_luts=None, match_std: float | None = None
                   ) -> list[StereoMeasurement]:
        """Ude eq. 10 correspondences of N left blob centres inside their right blobs, in 3-D.

        ``uv_left``, ``uv_right_blob``: ``(N, 2)`` px; ``blob_cov_*`` ``(N, 2, 2)``: the blobs'
        shape covariances (px^2; the left one sizes the template, the right one the search box);
        ``cov_uv_*`` (2x2 or ``(N, 2, 2)``): covariances of the measured centres (px^2,
        calibrated in advance as in Ude's Table 2), propagated to ``R_base``.
        ``template_luts``: optional colour look-up table per target; both images are then
        matched *colour-masked*: every pixel times its probability of having the target's
        colour, ``p / (p + 1)`` against the uniform outlier density 1, so the background
        around the blob turns black (clutter at other depths cannot pull the match) while the
        blob's outline, its strongest cue, stays sharp. ``match_std`` (px): use the
        template-following error model (:func:`following_covariance`, with ``cov_uv_left``)
        instead of independent left and right covariances (a scalar, or one per target).
        """
        p = self.params
        hh = int(p.template_half)
        uv_left = np.atleast_2d(np.asarray(uv_left, float))
        uv_rb = np.atleast_2d(np.asarray(uv_right_blob, float))
        bl = np.asarray(blob_cov_left, float).reshape(-1, 2, 2)
        bc = np.asarray(blob_cov_right, float).reshape(-1, 2, 2)
        H, W = image_left.shape[:2]
        out: list[StereoMeasurement | None] = [None] * len(uv_left)
        jobs = []
        with np.errstate(invalid="ignore"):  # non-finite inputs are caught below
            x_left = self.intr_l.undistort_normalized(uv_left).tolist()
            x_right = self.intr_r.undistort_normalized(uv_rb).tolist()
        for i, ((u, v), (ru, rv), (vu, vv), (a, b, c), (xl, yl), (xr, yr)) in enumerate(zip(
                uv_left.tolist(), uv_rb.tolist(), bc[:, [0, 1], [0, 1]].tolist(),
                bl[:, [0, 0, 1], [0, 1, 1]].tolist(), x_left, x_right, strict=True)):
            if not all(math.isfinite(z) for z in (u, v, ru, rv, vu, vv, a, b, c)):
                out[i] = _fail("non_finite_input", uv_left[i])
                continue
            lam = 0.5 * (a + c) + math.sqrt(max(0.25 * (a - c) ** 2 + b * b, 0.0))
            step = min(max(1.0, p.template_sigma * math.sqrt(max(lam, 0.0)) / max(hh, 1)),
                       p.max_spacing_px)
            r = hh * step
            if not (r <= u <= W - 1 - r and r <= v <= H - 1 - r):
                out[i] = _fail("template_out_of_image", uv_left[i])
                continue
            line = self._epipolar_interval(
                xl, yl, self.intr_r.fx * xr + self.intr_r.cx, self.intr_r.fy * yr + self.intr_r.cy,
                p.box_sigma * math.sqrt(max(vu, 0.25)), p.box_sigma * math.sqrt(max(vv, 0.25)))
            if line is None:
                out[i] = _fail("epipolar_line_misses_right_blob", uv_left[i])
                continue
            jobs.append((i, xl, yl, line, step))
        if jobs:
            self._match_jobs(image_left, image_right, uv_left, jobs, cov_uv_left, cov_uv_right,
                             out, template_luts, match_std)
        return out  # type: ignore[return-value]

    def _match_jobs(self, img_l, img_r, uv_left, jobs, cov_l, cov_r, out, luts=None,
                    match_std=None) -> None:
        p, k, hh = self.params, self._k, int(self.params.template_half)
        il, ir = self.intr_l, self.intr_r
        n = len(jobs)
        n_s = [math.floor((ln[2][1] - ln[2][0]) / st) + 1 for _, _, _, ln, st in jobs]
        L = max(n_s) + 2 * (hh + 1)  # strip columns: the interval plus template + parabola pad
        j = np.arange(L, dtype=float) - (hh + 1)
        d = np.array([st for *_, st in jobs])  # sample spacing (ideal px) per job
        kd = k[None, :] * d[:, None]  # (n, 2 hh + 1): row / template offsets
        # strips: ideal right pixels q0 + (s_lo + j d) t + r d nrm, for every job
        s0 = np.array([ln[2][0] for _, _, _, ln, _ in jobs])
        q0 = np.array([ln[0] for _, _, _, ln, _ in jobs])
        t = np.array([ln[1] for _, _, _, ln, _ in jobs])
        s = s0[:, None] + j[None, :] * d[:, None]  # (n, L)
        qx = q0[:, 0, None, None] + s[:, None, :] * t[:, 0, None, None] \
            - kd[:, :, None] * t[:, 1, None, None]
        qy = q0[:, 1, None, None] + s[:, None, :] * t[:, 1, None, None] \
            + kd[:, :, None] * t[:, 0, None, None]
        mx, my = ir.distort((qx - ir.cx) / ir.fx, (qy - ir.cy) / ir.fy)
        masks = [None if luts is None else luts[i] for i, *_ in jobs]
        src_l = [Prefiltered(img_l, p.prefilter_sigma, dr, lut, p.mask_closing)
                 for dr, lut in zip(d.tolist(), masks, strict=True)]
        src_r = [Prefiltered(img_r, p.prefilter_sigma, dr, lut, p.mask_closing)
                 for dr, lut in zip(d.tolist(), masks, strict=True)]
        strips = _read(src_r, mx, my)
        # templates: ideal left pixels around each left point, columns along its epipolar dir.
        ql = np.array([(il.fx * xl + il.cx, il.fy * yl + il.cy) for _, xl, yl, _, _ in jobs])
        tl = np.array([ln[3] for _, _, _, ln, _ in jobs])
        lx = ql[:, 0, None, None] + kd[:, None, :] * tl[:, 0, None, None] \
            - kd[:, :, None] * tl[:, 1, None, None]
        ly = ql[:, 1, None, None] + kd[:, None, :] * tl[:, 1, None, None] \
            + kd[:, :, None] * tl[:, 0, None, None]
        mx, my = il.distort((lx - il.cx) / il.fx, (ly - il.cy) / il.fy)
        tpls = _read(src_l, mx, my)
        few, frac = np.zeros(n, bool), np.zeros((n, 2))
        if luts is not None:  # templates with too little of the target's colour
            frac[:, 0] = target_fraction(luts, [i for i, *_ in jobs], tpls)
            few = frac[:, 0] < p.min_target_fraction
        sc = zncc_strips(strips, tpls)  # sc[r, m] <-> template centred on s_lo + (m - 1) d
        sc[few] = -1.0  # reported below
        valid = (np.arange(sc.shape[1]) >= 1) & (np.arange(sc.shape[1])[None, :]
                                                  <= np.array(n_s)[:, None])
        m = np.argmax(np.where(valid, sc, -np.inf), axis=1)
        # fine search: the template at sub-sample offsets around the best sample, then a parabola
        F = max(int(p.fine_steps), 1)
        s_c = s0 + (m - 1) * d
        s_f = s_c[:, None] + (np.arange(-F, F + 1) / F)[None, :] * d[:, None]  # (n, 2F + 1)
        wx = q0[:, 0, None, None, None] + (s_f[:, :, None, None] + kd[:, None, None, :]) \
            * t[:, 0, None, None, None] - kd[:, None, :, None] * t[:, 1, None, None, None]
        wy = q0[:, 1, None, None, None] + (s_f[:, :, None, None] + kd[:, None, None, :]) \
            * t[:, 1, None, None, None] + kd[:, None, :, None] * t[:, 0, None, None, None]
        mx, my = ir.distort((wx - ir.cx) / ir.fx, (wy - ir.cy) / ir.fy)
        win = _read(src_r, mx.reshape(n, -1, len(k)), my.reshape(n, -1, len(k))
                    ).reshape(n, 2 * F + 1, len(k), len(k), -1)
        fs = zncc_windows(win, tpls)
        fs[few] = -1.0
        b = np.clip(np.argmax(fs, axis=1), 1, 2 * F - 1)
        ar = np.arange(n)
        best = np.maximum(fs[ar, b], sc[ar, m])
        f_m, f_0, f_p = fs[ar, b - 1], fs[ar, b], fs[ar, b + 1]
        curv = f_m - 2.0 * f_0 + f_p
        with np.errstate(invalid="ignore", divide="ignore"):
            off = np.where(curv < 0, np.clip(0.5 * (f_m - f_p) / curv, -1.0, 1.0), 0.0)
        s_star = s_f[ar, b] + off * d / F
        if luts is not None and p.occlusion_check:  # the matched right window's target share
            frac[:, 1] = target_fraction(luts, [i for i, *_ in jobs], win[ar, b])
        mass = window_mass_px(frac, 2 * hh + 1, d[:, None])
        qr = q0 + s_star[:, None] * t
        good = best >= p.min_zncc
        for r in np.flatnonzero(~good).tolist():
            i = jobs[r][0]
            why = "few_target_pixels" if few[r] else "low_zncc"
            out[i] = _fail(why, uv_left[i], max(float(best[r]), 0.0))
        if not good.any():
            return
        rows = [jobs[r][0] for r in np.flatnonzero(good).tolist()]
        scores, mass = best[good].tolist(), mass[good]
        xl_a = np.array([(xl, yl) for _, xl, yl, _, _ in jobs])[good]
        xr_a = np.stack([(qr[good, 0] - ir.cx) / ir.fx, (qr[good, 1] - ir.cy) / ir.fy], 1)
        cl = np.asarray(cov_l, float) if cov_l is not None else None
        cr = np.asarray(cov_r, float) if cov_r is not None else None
        if cl is not None and cl.ndim == 3:
            cl = cl[rows]
        if cr is not None and cr.ndim == 3:
            cr = cr[rows]
        ur, vr = ir.distort(xr_a[:, 0], xr_a[:, 1])
        if match_std is None:
            C = joint_covariance(len(rows), cl, cr, None)
        else:  # the raw-pixel direction of the epipolar line at each match
            q1 = qr[good] + t[good]
            u1, v1 = ir.distort((q1[:, 0] - ir.cx) / ir.fx, (q1[:, 1] - ir.cy) / ir.fy)
            ms = np.asarray(match_std, float)
            C = following_covariance(np.zeros((2, 2)) if cl is None else cl,
                                     ms[rows] if ms.ndim else ms,
                                     np.stack([u1 - ur, v1 - vr], 1))
        P, R = self._triangulate_normalised(xl_a, xr_a, C)
        depth_l = P @ self.P_left[2, :3] + self.P_left[2, 3]
        depth_r = P @ self.P_right[2, :3] + self.P_right[2, 3]
        finite = np.isfinite(P).all(1) & np.isfinite(R).all((1, 2))
        for r, i in enumerate(rows):
            if not finite[r]:
                out[i] = _fail("degenerate_triangulation", uv_left[i], scores[r])
            elif depth_l[r] <= 0.0 or depth_r[r] <= 0.0:
                out[i] = _fail("behind_camera", uv_left[i], scores[r])
            else:
                out[i] = StereoMeasurement(True, "", P[r], R[r], uv_left[i].copy(),
                                           np.array([ur[r], vr[r]]), scores[r], mass[r])

    def match(self, image_left, image_right, uv_left, blob_cov_left, uv_right_blob,
              blob_cov_right, cov_uv_left, cov_uv_right, template_lut=None
              ) -> StereoMeasurement:
        """:meth:`match_many` for one target."""
        return self.match_many(image_left, image_right, [uv_left], [blob_cov_left],
                               [uv_right_blob], [blob_cov_right], cov_uv_left, cov_uv_right,
                               None if template_lut is None else [template_lut])[0]


def epipolar_direction(cam_left: CameraModel, cam_right: CameraModel, p_base: np.ndarray
                       ) -> np.ndarray:
    """Unit raw-pixel direction in the right image of moving ``p_base`` along the left eye's
    ray (where a stereo match error moves the right point)."""
    ray = p_base - cam_left.T_base_cam[:3, 3]
    ray = ray / np.linalg.norm(ray)
    t = cam_right.project_base(p_base + 0.01 * ray) - cam_right.project_base(p_base)
    return t / np.linalg.norm(t)


def match_and_triangulate(image_left, image_right, cam_left: CameraModel,
                          cam_right: CameraModel, uv_left, blob_cov_left, uv_right_blob,
                          blob_cov_right, cov_uv_left, cov_uv_right,
                          params: StereoParams = StereoParams()) -> StereoMeasurement:
    """One-shot :meth:`StereoRig.match` (builds the rig; build one rig per frame instead)."""
    return StereoRig(cam_left, cam_right, params).match(
        image_left, image_right, uv_left, blob_cov_left, uv_right_blob, blob_cov_right,
        cov_uv_left, cov_uv_right)
