"""EM colour-blob tracking of Ude & Atkeson (eqs. 1-7).

K blob processes, each a 2-D Gaussian shape (centre ``x_l``, covariance ``Sigma_l``, eq. 5) times
a fixed colour model ``p(I|Theta_l)`` (eqs. 6-7), plus a uniform outlier process Theta_0 (eq. 1).
Per frame, E-steps (posteriors, eq. 2) and M-steps (posterior-weighted mean and covariance of
pixel positions, mixture weights) alternate until the centres move less than ``em_tol_px``,
starting from the previous frame's blobs (optionally advanced by their image velocity).

Region of interest (the paper warps an ROI per blob onto a fixed-size window; the equivalent
here): for each blob an axis-aligned box of +-(``roi_k_sigma`` sigma + ``margin_px``) around its
predicted centre, sampled on a grid with an integer stride chosen so that no box has more than
``roi_side`` samples per side. Each sample stands for a ``stride x stride`` cell: it carries the
area ``stride^2`` as a weight in the M-step and the cell's internal position variance
``(stride^2 - 1)/12`` is added to the covariance, so estimates match full-resolution ones. Where
boxes overlap, the samples of the later box are dropped. The number of processed pixels is
therefore at most ``K roi_side^2``, whatever the image size. The outlier density is uniform over
the sampled area and over colour space (unit volume): ``1 / A_roi``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from humimic.perception.cues.color_models import ColorLUT

_TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class EMParams:
    roi_k_sigma: float = 3.0
    margin_px: float = 4.0
    roi_side: int = 20
    em_iterations: int = 6
    em_tol_px: float = 1.0
    """Stop iterating when no centre moved more than this (px). The first M-step from a
    well-predicted start lands within ~0.1 px of convergence, so 1 px mostly means 1 EM
    iteration per frame (measured: same accuracy as iterating to 0.05 px)."""
    min_var_px2: float = 1.0
    max_var_px2: float = 150.0**2
    predict_motion: bool = True
    max_step_px: float = 40.0
    """Largest predicted displacement per frame (px)."""
    prior_px: float = 0.0
    """Strength (in pixels of support) of a Gaussian prior pulling each centre towards its
    predicted position in the M-step (MAP instead of ML); 0 = the paper's plain ML M-step."""


def quad_features(uv: np.ndarray, cell_var: np.ndarray | float = 0.0) -> np.ndarray:
    """Rows ``[u^2, u v, v^2, u, v, 1, cell_var]`` ``(7, M)`` of samples ``uv (M, 2)``.

    The first six rows make the Gaussian's log a dot product (:func:`log_shape_coeffs`); with
    the last they are also every sufficient statistic the M-step needs. ``cell_var`` is the
    internal position variance per axis of the cell a sample stands for, ``(s^2 - 1)/12`` for an
    ``s x s`` cell of pixels.
    """
    u, v = uv[:, 0], uv[:, 1]
    F = np.empty((7, len(u)))
    np.multiply(u, u, out=F[0])
    np.multiply(u, v, out=F[1])
    np.multiply(v, v, out=F[2])
    F[3], F[4], F[5], F[6] = u, v, 1.0, cell_var
    return F


def log_shape_coeffs(centres: np.ndarray, covs: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``C (K, 6)`` with ``log(scale_l N(u; x_l, Sigma_l)) = C_l . quad_features(u)[:6]``.

    Scalar arithmetic per blob (K is small); ``scale`` 0 gives a vanishing density.  # Ude eq. 5
    """
    rows = []
    for (x, y), (a, b, c), w in zip(centres.tolist(), covs[:, [0, 0, 1], [0, 1, 1]].tolist(),
                                    np.asarray(scale, float).tolist(), strict=True):
        det = a * c - b * b
        ia, ib, ic = c / det, -b / det, a / det  # Sigma^-1
        const = -0.5 * (ia * x * x + 2.0 * ib * x * y + ic * y * y) \
            - math.log(_TWO_PI * math.sqrt(det)) + math.log(max(w, 1e-300))
        rows.append((-0.5 * ia, -ib, -0.5 * ic, ia * x + ib * y, ib * x + ic * y, const))
    return np.array(rows)


def shape_density(uv: np.ndarray, centres: np.ndarray, covs: np.ndarray) -> np.ndarray:
    """2-D Gaussian ``p(u | Theta_l)`` of samples ``uv (M, 2)`` for K blobs: ``(K, M)``.  # eq. 5"""
    F = quad_features(uv)[:6]
    return np.exp(log_shape_coeffs(centres, covs, np.ones(len(centres))) @ F)


def e_step(uv: np.ndarray, color_lik: np.ndarray, centres: np.ndarray, covs: np.ndarray,
           weights: np.ndarray, outlier_density: float, area: np.ndarray | float = 1.0,
           with_loglik: bool = True, features: np.ndarray | None = None
           ) -> tuple[np.ndarray, float]:
    """Posteriors ``p_{u,l}`` ``(K+1, M)`` (row 0: outlier) and the log-likelihood.

    ``color_lik (K, M)`` is ``p(I_u | Theta_l)``; ``weights (K+1,)`` the mixture weights
    ``omega`` (index 0: outlier); the log-likelihood is ``sum_u area_u log P(I_u, u | Theta)``
    (0.0 unless ``with_loglik``). ``features``: precomputed :func:`quad_features` of ``uv``.
    """
    F = quad_features(uv) if features is None else features
    joint = np.empty((len(centres) + 1, F.shape[1]))
    joint[0] = weights[0] * outlier_density
    # omega_l p(u|Theta_l) p(I_u|Theta_l): Ude eqs. 4-7 (the shape term via one matrix product)
    np.exp(log_shape_coeffs(centres, covs, weights[1:]) @ F[:6], out=joint[1:])
    joint[1:] *= color_lik
    total = joint.sum(axis=0)  # Ude eq. 1
    np.maximum(total, 1e-300, out=total)
    joint /= total  # Ude eq. 2
    loglik = float(np.dot(np.broadcast_to(area, total.shape), np.log(total))) if with_loglik \
        else 0.0  # Ude eq. 3 (log)
    return joint, loglik


def m_step(post: np.ndarray, features: np.ndarray, area: np.ndarray | float = 1.0
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weighted ML centres ``(K, 2)``, covariances ``(K, 2, 2)``, mixture weights ``(K+1,)``.

    Sample weights are ``post[l] * area``; ``features`` from :func:`quad_features` (its
    ``cell_var`` row is added to the variances). Also returns each blob's support
    ``sum_u area_u p_{u,l}`` (pixels, ``(K,)``); blobs without support get NaN parameters.
    """
    S = (post * area) @ features.T  # (K+1, 7): every sufficient statistic in one product
    weights = S[:, 5] / S[:, 5].sum()
    W = S[1:, 5]
    with np.errstate(invalid="ignore", divide="ignore"):
        m = S[1:] / np.where(W > 0, W, np.nan)[:, None]  # E[u^2], E[uv], E[v^2], E[u], E[v]
    cx, cy = m[:, 3], m[:, 4]
    covs = np.empty((len(W), 2, 2))
    covs[:, 0, 0] = m[:, 0] - cx * cx + m[:, 6]
    covs[:, 0, 1] = covs[:, 1, 0] = m[:, 1] - cx * cy
    covs[:, 1, 1] = m[:, 2] - cy * cy + m[:, 6]
    return m[:, 3:5].copy(), covs, weights, W


def clamp_covariances(covs: np.ndarray, min_var: float, max_var: float) -> np.ndarray:
    """Clamp the eigenvalues of 2x2 covariances into ``[min_var, max_var]``."""
    bad = False
    for a, b, c in covs[:, [0, 0, 1], [0, 1, 1]].tolist():  # scalar checks: K is small
        half_tr = 0.5 * (a + c)
        disc = math.sqrt(max(half_tr * half_tr - (a * c - b * b), 0.0))
        bad |= not (half_tr - disc >= min_var and half_tr + disc <= max_var)
    if not bad:
        return covs
    lam, vec = np.linalg.eigh(covs)
    lam = np.clip(lam, min_var, max_var)
    return (vec * lam[:, None, :]) @ np.swapaxes(vec, 1, 2)


@dataclass
class RoiSamples:
    """Pixels sampled from the blobs' ROIs (see module docstring)."""

    pix: np.ndarray
    """(M, 3) uint8 colours."""
    uv: np.ndarray
    """(M, 2) float pixel coordinates (u right, v down)."""
    area: np.ndarray
    """(M,) pixels each sample stands for (stride^2)."""
    cell_var: np.ndarray
    """(M,) internal position variance of each sample's cell, (stride^2 - 1)/12."""


def roi_half_sides(covs: np.ndarray, params: EMParams) -> np.ndarray:
    """``(K, 2)`` half sides (px) of each blob's region of interest: +-(``roi_k_sigma`` sigma +
    ``margin_px``) along u and v (``covs`` ``(K, 2, 2)``)."""
    sd = np.sqrt(np.maximum(np.asarray(covs, float)[:, [0, 1], [0, 1]], 0.0))
    return params.roi_k_sigma * sd + params.margin_px


def rois_overlap(centre_a, cov_a, centre_b, cov_b, params: EMParams) -> bool:
    """Whether two blobs' regions of interest (:func:`roi_half_sides`) overlap: only then can
    EM hand pixels of one to the other."""
    h = roi_half_sides(np.stack([cov_a, cov_b]), params)
    return bool(np.all(np.abs(np.asarray(centre_a, float) - np.asarray(centre_b, float))
                       <= h[0] + h[1]))


def roi_samples(image: np.ndarray, centres: np.ndarray, covs: np.ndarray,
                params: EMParams) -> RoiSamples:
    """Sample each blob's box (+-(roi_k_sigma sigma + margin)) with a stride capping it at
    roi_side^2.

    Samples of a box inside an earlier blob's box are dropped (each pixel counted once).
    """
    H, W = image.shape[:2]
    boxes: list[tuple[int, int, int, int]] = []
    pix, us, vs, ss = [], [], [], []
    for (cx, cy), (hx, hy) in zip(centres.tolist(), roi_half_sides(covs, params).tolist(),
                                  strict=True):
        if not (math.isfinite(cx + cy + hx + hy)):
            continue
        x0, x1 = max(0, math.floor(cx - hx)), min(W - 1, math.ceil(cx + hx))
        y0, y1 = max(0, math.floor(cy - hy)), min(H - 1, math.ceil(cy + hy))
        if x1 < x0 or y1 < y0:
            continue
        s = max(1, -(-max(x1 - x0 + 1, y1 - y0 + 1) // params.roi_side))
        x0 += (x1 - x0) % s // 2  # centre the grid in the box
        y0 += (y1 - y0) % s // 2
        xs = np.arange(x0, x1 + 1, s)
        ys = np.arange(y0, y1 + 1, s)
        block = image[y0:y1 + 1:s, x0:x1 + 1:s].reshape(-1, 3)
        grid = np.empty((2, len(ys), len(xs)), np.intp)  # u varies fastest, as the block
        grid[0] = xs
        grid[1] = ys[:, None]
        u, v = grid[0].ravel(), grid[1].ravel()
        overlaps = [b for b in boxes if b[0] <= x1 and x0 <= b[1] and b[2] <= y1 and y0 <= b[3]]
        if overlaps:
            keep = np.ones(u.shape, bool)
            for bx0, bx1, by0, by1 in overlaps:
                keep &= ~((u >= bx0) & (u <= bx1) & (v >= by0) & (v <= by1))
            block, u, v = block[keep], u[keep], v[keep]
        boxes.append((x0, x1, y0, y1))
        pix.append(block)
        us.append(u)
        vs.append(v)
        ss.append(np.full(len(u), float(s * s)))
    if not pix:
        z = np.zeros(0)
        return RoiSamples(np.zeros((0, 3), np.uint8), np.zeros((0, 2)), z, z)
    area = np.concatenate(ss)
    uv = np.empty((len(area), 2))
    uv[:, 0] = np.concatenate(us)
    uv[:, 1] = np.concatenate(vs)
    return RoiSamples(np.concatenate(pix), uv, area, (area - 1.0) / 12.0)


@dataclass
class BlobFrame:
    """Result of one tracker update (arrays over all K blobs; inactive blobs keep old values)."""

    centres: np.ndarray
    covs: np.ndarray
    weights: np.ndarray
    support_px: np.ndarray
    """Pixels assigned to each blob (sum of area-weighted posteriors)."""
    fill: np.ndarray
    """support_px / (4 pi sqrt(det Sigma)): ~1 for a solid ellipse, -> 0 when the blob is lost."""
    active: np.ndarray
    n_iter: int = 0
    loglik: float = 0.0
    n_samples: int = 0


class BlobTracker:
    """Tracks K colour blobs in one image stream (blob ``l`` uses ``color_luts[l]``)."""

    def __init__(self, color_luts: list[ColorLUT], params: EMParams = EMParams()) -> None:
        self.luts = list(color_luts)
        self.params = params
        K = len(self.luts)
        self.centres = np.zeros((K, 2))
        self.covs = np.repeat(np.eye(2)[None] * 25.0, K, 0)
        self.velocity = np.zeros((K, 2))  # px per frame
        self.active = np.zeros(K, bool)
        self._age = np.zeros(K, int)
        self.weights = np.full(K + 1, 1.0 / (K + 1))

    @property
    def K(self) -> int:
        return len(self.luts)

    @property
    def age(self) -> np.ndarray:
        """Frames each blob has been tracked since its last start."""
        return self._age.copy()

    def start(self, k: int, centre, cov) -> None:
        """(Re)start blob ``k`` at ``centre`` (px) with shape covariance ``cov`` (px^2)."""
        self.centres[k] = centre
        self.covs[k] = cov
        self.velocity[k] = 0.0
        self.active[k] = True
        self._age[k] = 0
        self.weights[k + 1] = max(self.weights[k + 1], 0.05)

    def stop(self, k: int) -> None:
        self.active[k] = False

    def _predicted_centres(self, idx: np.ndarray) -> np.ndarray:
        centres = self.centres[idx].copy()
        if self.params.predict_motion:
            for row, k in enumerate(idx.tolist()):
                if self._age[k] > 0:
                    dx, dy = self.velocity[k].tolist()
                    n = math.hypot(dx, dy)
                    f = min(1.0, self.params.max_step_px / n) if n > 0 else 0.0
                    centres[row, 0] += f * dx
                    centres[row, 1] += f * dy
        return centres

    def update(self, image: np.ndarray) -> BlobFrame:
        """Run EM on ``image`` (H x W x 3 uint8 RGB) for the active blobs."""
        p = self.params
        idx = np.flatnonzero(self.active)
        if idx.size == 0:
            return self._frame(np.zeros(self.K), 0, 0.0, 0)
        centres = self._predicted_centres(idx)
        c_pred = centres.copy()
        covs = self.covs[idx].copy()
        roi = roi_samples(image, centres, covs, p)
        M = len(roi.area)
        if M == 0:
            return self._frame(np.zeros(self.K), 0, 0.0, 0)
        color_lik = np.empty((idx.size, M))
        done: dict[int, int] = {}
        for row, k in enumerate(idx.tolist()):
            key = id(self.luts[k])
            if key in done:
                color_lik[row] = color_lik[done[key]]
            else:
                color_lik[row] = self.luts[k].lookup(roi.pix)
                done[key] = row
        features = quad_features(roi.uv, roi.cell_var)
        outlier_density = 1.0 / float(roi.area.sum())
        weights = np.append(self.weights[0], self.weights[1 + idx])
        weights /= weights.sum()
        support = np.zeros(idx.size)
        loglik, it = 0.0, 0
        for it in range(1, p.em_iterations + 1):  # noqa: B007
            post, loglik = e_step(roi.uv, color_lik, centres, covs, weights, outlier_density,
                                  roi.area, with_loglik=False, features=features)
            c_new, s_new, weights, support = m_step(post, features, roi.area)
            if p.prior_px > 0.0:
                c_new = (support[:, None] * c_new + p.prior_px * c_pred) / (
                    support[:, None] + p.prior_px)
            if not np.isfinite(c_new[:, 0]).all():  # no support: keep the previous blob
                dead = ~np.isfinite(c_new[:, 0])
                c_new[dead], s_new[dead] = centres[dead], covs[dead]
            s_new = clamp_covariances(s_new, p.min_var_px2, p.max_var_px2)
            shift = float(np.abs(c_new - centres).max())
            centres, covs = c_new, s_new
            np.maximum(weights, 1e-6, out=weights)
            if shift < p.em_tol_px:
                break
        self.velocity[idx] = centres - self.centres[idx]
        self.centres[idx], self.covs[idx] = centres, covs
        self.weights[0] = weights[0]
        self.weights[1 + idx] = weights[1:]
        self._age[idx] += 1
        full_support = np.zeros(self.K)
        full_support[idx] = support
        return self._frame(full_support, it, loglik, M)

    def _frame(self, support, n_iter, loglik, n_samples) -> BlobFrame:
        det = self.covs[:, 0, 0] * self.covs[:, 1, 1] - self.covs[:, 0, 1] ** 2
        fill = support / (4.0 * np.pi * np.sqrt(np.maximum(det, 1e-12)))
        return BlobFrame(self.centres.copy(), self.covs.copy(), self.weights.copy(),
                         support, fill, self.active.copy(), n_iter, loglik, n_samples)
