"""Random blob hypotheses and their colour scores for detection (Ude & Atkeson eqs. 8-9).

Pure functions: hypothesis shapes (random within size limits, or fitted to the colour map),
the fixed-size window warped onto each hypothesis, the colour sum f over it (eq. 8), the
phase-one threshold (eq. 9) and the proposal of centres. Used by
:class:`humimic.perception.blobs.detection.DetectingTracker`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import cv2
import numpy as np

from humimic.perception.blobs.em_blobs import clamp_covariances
from humimic.perception.cues.color_models import ColorLUT

Allowed = Callable[[np.ndarray], np.ndarray]
"""``allowed(points (n, P, 2) px) -> (n, P) bool``: which window points a hypothesis may see."""


def random_hypotheses(rng: np.random.Generator, centres: np.ndarray, sigma_min: float,
                      sigma_max: float) -> np.ndarray:
    """Covariances ``(n, 2, 2)`` for hypothesis ``centres (n, 2)``: axes log-uniform in
    ``[sigma_min, sigma_max]``, orientation uniform."""
    n = len(centres)
    sig = np.exp(rng.uniform(math.log(sigma_min), math.log(sigma_max), size=(n, 2)))
    th = rng.uniform(0.0, math.pi, size=n)
    c, s = np.cos(th), np.sin(th)
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    return (R * (sig**2)[:, None, :]) @ np.swapaxes(R, 1, 2)


def window_points(centres: np.ndarray, covs: np.ndarray, side: int, k_sigma: float
                  ) -> np.ndarray:
    """Fixed ``side x side`` grid over ``[-k, k]^2`` warped by each hypothesis: ``(n, side^2, 2)``.

    ``u = x_l + L_l g`` with ``L_l L_l^T = Sigma_l`` (the paper's affine ROI warping).
    """
    g = _unit_grid(int(side), float(k_sigma))
    a, b, c = covs[:, 0, 0], covs[:, 0, 1], covs[:, 1, 1]
    l11 = np.sqrt(a)
    l21 = b / l11
    l22 = np.sqrt(np.maximum(c - l21 * l21, 0.0))  # L = [[l11, 0], [l21, l22]]
    out = np.empty((len(centres), len(g), 2))
    out[..., 0] = centres[:, 0, None] + l11[:, None] * g[None, :, 0]
    out[..., 1] = centres[:, 1, None] + l21[:, None] * g[None, :, 0] + l22[:, None] * g[None, :, 1]
    return out


@functools.lru_cache(maxsize=8)
def _grid_points(H: int, W: int, step: int) -> np.ndarray:
    """Centres ``(n, 2)`` (u, v) of the coarse colour map's cells, row-major."""
    vv, uu = np.mgrid[step // 2:H:step, step // 2:W:step]
    pts = np.stack([uu.ravel(), vv.ravel()], -1).astype(float)
    pts.flags.writeable = False
    return pts


@functools.lru_cache(maxsize=8)
def _unit_grid(side: int, k_sigma: float) -> np.ndarray:
    g1 = np.linspace(-k_sigma, k_sigma, side)
    g = np.stack(np.meshgrid(g1, g1, indexing="xy"), -1).reshape(-1, 2)
    g.flags.writeable = False
    return g


def color_sums(image: np.ndarray, lut: ColorLUT, centres: np.ndarray, covs: np.ndarray,
               side: int, k_sigma: float, score: str = "density",
               allowed: Allowed | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``f(Theta_l) = sum_u p(I_u | Theta_l)`` over each warped window (nearest pixel; points off
    the image count 0), and the fraction of window points with ``p > 1`` (uniform).  # Ude eq. 8

    ``score='posterior'`` sums ``p / (p + 1)`` instead: each pixel's probability of having the
    target's colour rather than the uniform outlier's, in [0, 1), so f counts target-coloured
    pixels however peaked the colour density is. ``allowed(points (n, P, 2)) -> (n, P) bool``
    masks window points out (they count 0, as off the image): see :func:`blob_gate`.
    """
    H, W = image.shape[:2]
    pts = np.rint(window_points(centres, covs, side, k_sigma)).astype(np.intp)
    inside = (pts[..., 0] >= 0) & (pts[..., 0] < W) & (pts[..., 1] >= 0) & (pts[..., 1] < H)
    if allowed is not None:
        inside &= allowed(pts)
    u = np.clip(pts[..., 0], 0, W - 1)
    v = np.clip(pts[..., 1], 0, H - 1)
    if image.flags.c_contiguous:  # image[v, u], 4x faster as a flat take
        pix = image.reshape(H * W, -1).take(v * W + u, axis=0)
    else:
        pix = image[v, u]
    p = lut.lookup(pix).astype(np.float64) * inside
    inlier = (p > 1.0).mean(axis=1)
    if score == "posterior":
        p = p / (p + 1.0)
    elif score != "density":
        raise ValueError(f"score must be 'density' or 'posterior', not {score!r}")
    return p.sum(axis=1), inlier


def detection_threshold(mean_f: float, max_f: float, lam: float) -> float:
    """``r_l = (1 - lambda) E f + lambda max f``.  # Ude eq. 9"""
    return (1.0 - lam) * mean_f + lam * max_f


def propose_centres(rng: np.random.Generator, n: int, image_shape: tuple[int, int],
                    coarse_lik: np.ndarray | None, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` centres (px): uniform, or half uniform and half from ``coarse_lik`` (a colour
    probability map sampled at the centres of ``grid``-px cells, cell ``(i, j)`` covering
    ``[j grid, (j + 1) grid) x [i grid, (i + 1) grid)``), uniform within the drawn cell. Also
    returns which centres are uniform draws (the paper's random hypotheses)."""
    H, W = image_shape
    out = rng.uniform((0.0, 0.0), (W - 1.0, H - 1.0), size=(n, 2))
    uniform = np.ones(n, bool)
    if coarse_lik is None or n < 2:
        return out, uniform
    c = np.cumsum(coarse_lik.ravel(), dtype=np.float64)
    if not c[-1] > 0.0:
        return out, uniform
    m = n // 2
    uniform[:m] = False
    idx = np.minimum(np.searchsorted(c, rng.uniform(0.0, c[-1], size=m), side="right"),
                     c.size - 1)
    iy, ix = np.divmod(idx, coarse_lik.shape[1])
    within = rng.uniform(0.0, grid, size=(m, 2))  # the cell :func:`fitted_hypotheses` reads
    out[:m] = np.clip(np.stack([ix, iy], -1) * grid + within, 0.0, (W - 1.0, H - 1.0))
    return out, uniform


def fitted_hypotheses(coarse_post: np.ndarray, centres: np.ndarray, grid: int, radius_cells: int,
                      sigma_min: float, sigma_max: float, labels: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Centres and covariances fitted to the colour map around proposed centres (px).

    ``coarse_post`` is the target-colour probability (in [0, 1]) on a grid of spacing ``grid``
    px (cell ``(i, j)`` centred at ``(j grid + grid // 2, i grid + grid // 2)``); around each
    centre's cell, the probability-weighted mean and covariance of the cell centres within
    ``radius_cells`` (plus a cell's own spread, grid^2 / 12) give a hypothesis shaped like the
    blob there, its axes clamped into ``[sigma_min, sigma_max]``. Only the cells of the blob the
    centre fell in count (the 8-connected component of cells with probability >= 1/2; a centre
    outside every blob takes the whole neighbourhood): a small hand next to the head is fitted
    alone, not as a smear over both. ``labels``: :func:`coarse_blobs` of ``coarse_post``, if
    the caller has them already.
    """
    h, w = coarse_post.shape
    if labels is None:
        labels = coarse_blobs(coarse_post)
    off = np.arange(-radius_cells, radius_cells + 1)
    ci = np.clip(np.floor(centres[:, 1] / grid).astype(int), 0, h - 1)
    cj = np.clip(np.floor(centres[:, 0] / grid).astype(int), 0, w - 1)
    ii, jj = np.broadcast_arrays(ci[:, None, None] + off[None, :, None],
                                 cj[:, None, None] + off[None, None, :])
    inside = (ii >= 0) & (ii < h) & (jj >= 0) & (jj < w)
    ii_c, jj_c = np.clip(ii, 0, h - 1), np.clip(jj, 0, w - 1)
    own = own_blob(labels, centres, grid)
    same = (labels[ii_c, jj_c] == own[:, None, None]) | (own == 0)[:, None, None]
    wgt = np.where(inside & same, coarse_post[ii_c, jj_c], 0.0)
    wgt = wgt.reshape(len(centres), -1)
    u = (jj * grid + grid // 2).reshape(len(centres), -1).astype(float)
    v = (ii * grid + grid // 2).reshape(len(centres), -1).astype(float)
    W = np.maximum(wgt.sum(1), 1e-12)
    mu = np.stack([(wgt * u).sum(1), (wgt * v).sum(1)], 1) / W[:, None]
    du, dv = u - mu[:, 0, None], v - mu[:, 1, None]
    cov = np.empty((len(centres), 2, 2))
    cov[:, 0, 0] = (wgt * du * du).sum(1) / W + grid * grid / 12.0
    cov[:, 0, 1] = cov[:, 1, 0] = (wgt * du * dv).sum(1) / W
    cov[:, 1, 1] = (wgt * dv * dv).sum(1) / W + grid * grid / 12.0
    lam, vec = np.linalg.eigh(cov)
    lam = np.clip(lam, sigma_min**2, sigma_max**2)
    return mu, (vec * lam[:, None, :]) @ np.swapaxes(vec, 1, 2)


def refine_hypotheses(image: np.ndarray, lut: ColorLUT, centres: np.ndarray, covs: np.ndarray,
                      side: int, k_sigma: float, pad_px: float, sigma_min: float,
                      sigma_max: float, allowed: Allowed | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """One full-resolution moment step for hypotheses fitted on the coarse colour map.

    A coarse fit places a blob narrower than a grid cell on the cell's centre (up to half a
    cell off) and can only floor its width at ``grid^2 / 12``: its eq. 8 window (+-k sigma of
    that shape) then slides off a thin hand and the hand's colour sum stays under eq. 9's
    threshold frame after frame. Here each hypothesis' window is widened by ``pad_px`` per axis
    (``Sigma + pad^2 I``), sampled on a ``side x side`` grid (nearest pixel, as
    :func:`color_sums`), and the centre and covariance become the posterior-weighted
    (``p / (p + 1)``) mean and covariance of the sample points -- the EM tracker's own moment
    update (Ude eqs. 4-5, one step, one blob). Axes clamped into ``[sigma_min, sigma_max]``;
    a window with no target colour keeps its hypothesis. ``allowed`` (as in
    :func:`color_sums`) masks points out: with :func:`blob_gate` the widened window of a hand
    does not take in the head beside it.
    """
    H, W = image.shape[:2]
    wide = covs + pad_px**2 * np.eye(2)
    pts = window_points(centres, wide, side, k_sigma)
    q = np.rint(pts).astype(np.intp)
    inside = (q[..., 0] >= 0) & (q[..., 0] < W) & (q[..., 1] >= 0) & (q[..., 1] < H)
    if allowed is not None:
        inside &= allowed(q)
    u, v = np.clip(q[..., 0], 0, W - 1), np.clip(q[..., 1], 0, H - 1)
    p = lut.lookup(image[v, u]).astype(np.float64) * inside
    wgt = p / (p + 1.0)
    tot = wgt.sum(1)
    ok = tot > 1.0
    mu = np.einsum("np,npi->ni", wgt, pts) / np.maximum(tot, 1e-12)[:, None]
    d = pts - mu[:, None, :]
    cov = np.einsum("np,npi,npj->nij", wgt, d, d) / np.maximum(tot, 1e-12)[:, None, None]
    cov = clamp_covariances(cov, sigma_min**2, sigma_max**2)
    return np.where(ok[:, None], mu, centres), np.where(ok[:, None, None], cov, covs)


def coarse_blobs(coarse_post: np.ndarray) -> np.ndarray:
    """Blob labels ``(h, w)`` int of the coarse colour map: the 8-connected components of its
    cells with target-colour probability >= 1/2 numbered from 1, 0 elsewhere."""
    _, labels = cv2.connectedComponents((coarse_post >= 0.5).astype(np.uint8), connectivity=8)
    return labels


def cell_labels(labels: np.ndarray, points: np.ndarray, grid: int) -> np.ndarray:
    """The blob label of the coarse cell holding each point ``(..., 2)`` (u, v px; cell
    ``(i, j)`` covers ``[j grid, (j + 1) grid) x [i grid, (i + 1) grid)``, clamped to the map)."""
    h, w = labels.shape
    i = np.clip(np.floor(points[..., 1] / grid).astype(np.intp), 0, h - 1)
    j = np.clip(np.floor(points[..., 0] / grid).astype(np.intp), 0, w - 1)
    return labels[i, j]


def own_blob(labels: np.ndarray, centres: np.ndarray, grid: int) -> np.ndarray:
    """The blob label owning each hypothesis centre ``(n, 2)`` (0: in no blob)."""
    return cell_labels(labels, centres, grid)


def blob_gate(labels: np.ndarray, own: np.ndarray, grid: int) -> Allowed:
    """``allowed`` for :func:`color_sums` / :func:`refine_hypotheses`: hypothesis ``l`` sees the
    pixels of its own blob ``own[l]`` and of the cells in no blob (label 0: a target thinner
    than a cell may fall between the map's samples) that border no other blob (a blob's rim
    pixels lie in the unlabelled cells around it), not those of the other blobs -- a hand
    beside the head is refined and scored alone. ``own[l] < 0``: no gate for that hypothesis."""
    lab = labels.astype(np.float32)
    kernel = np.ones((3, 3), np.uint8)
    big = np.float32(labels.max() + 1)
    nb_max = cv2.dilate(lab, kernel, borderType=cv2.BORDER_REPLICATE)  # 8-neighbourhood
    nb_min = -cv2.dilate(-np.where(labels > 0, lab, big), kernel,
                         borderType=cv2.BORDER_REPLICATE)  # smallest blob label, big if none

    def allowed(points: np.ndarray) -> np.ndarray:
        h, w = labels.shape
        i = np.clip(np.floor(points[..., 1] / grid).astype(np.intp), 0, h - 1)
        j = np.clip(np.floor(points[..., 0] / grid).astype(np.intp), 0, w - 1)
        o = own[:, None]
        lab_p, hi, lo = labels[i, j], nb_max[i, j], nb_min[i, j]
        free = (lab_p == 0) & ((hi == 0) | ((lo == o) & (hi == o)))
        return (o < 0) | (lab_p == o) & (o > 0) | free
    return allowed
