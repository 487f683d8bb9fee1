"""The colour cue (Menezes sec. 4.1.3): multi-patch colour histograms and the Bhattacharyya
distance, for all particles at once.

A *patch* is a rectangle fixed to the target in template units: ``(cx, cy, w, h)`` relative
to the state's ``(u, v)`` and scaled by its ``s`` (e.g. the head and the torso below it,
Menezes Fig. 8). Its colour model is one ``N_bi``-bin normalised histogram per RGB channel.
Histograms are estimated from a ``grid x grid`` lattice of pixels in each rectangle (one
gather and one ``np.bincount`` for every particle and patch; with the grid as fine as the
pixels it is the exact histogram of the rectangle, as ``cv2.calcHist`` computes it).
Samples off the image are left out; a patch wholly off the image has an empty histogram,
at the largest distance (1) from any reference.

* eq. 6 -- :func:`color_log_likelihood`: ``-sum_c sum_p lambda_pc D^2(h_pc, h_ref,pc) /
  (2 sigma_c^2)`` with :func:`bhattacharyya` ``D = sqrt(1 - sum_b sqrt(h_b h_ref,b))``
  (OpenCV's ``HISTCMP_BHATTACHARYYA`` for normalised histograms).
* :func:`chromaticity` -- the image in normalised rgb, for histograms that a change of
  shading (a limb turning towards or away from the light) leaves alone.
* eq. 13 -- :func:`update_reference`: ``h_ref,k = (1 - kappa) h_ref,k-1 + kappa h_E[x_k]``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from humimic.maths.jit import njit

HEAD_TORSO_PATCHES = np.array([[0.0, 0.0, 0.8, 1.0],    # head (head width = 1)
                               [0.0, 1.9, 1.6, 1.2]])   # torso below it
"""The ICU tracker's two patches (Menezes Fig. 8), in head widths from the head centre."""


@dataclass(frozen=True)
class QuantizedImage:
    """An RGB image's bin indices, one flat plane per channel, ready for gathers: plane ``c``
    holds ``bin + c (bins + 1)`` per pixel plus, at index ``H * W``, a sentinel in the extra
    bin ``bins`` that samples off the image are pointed at (counted, then dropped)."""

    planes: np.ndarray
    """``(3, H * W + 1)`` int32"""
    height: int
    width: int
    bins: int


def chromaticity(image: np.ndarray, dark: float = 24.0) -> np.ndarray:
    """Normalised rgb chromaticity ``255 (R, G, B) / (R + G + B)`` of an RGB uint8 image, as
    uint8 ``(H, W, 3)``: unchanged when the light on a surface scales its colour (a limb
    turning away from the lamp keeps its chromaticity, not its RGB). Pixels darker than
    ``dark`` (mean of the channels) are grey (85, 85, 85): their chromaticity is noise."""
    rgb = np.asarray(image, np.uint8).astype(np.uint16)
    total = rgb.sum(axis=-1, keepdims=True, dtype=np.uint16)                 # <= 765
    chroma = (rgb * 255 + total // 2) // np.maximum(total, 1)               # rounded, <= 65407
    return np.where(total >= 3.0 * dark, chroma, 85).astype(np.uint8)


def quantize(image: np.ndarray, bins: int = 32) -> QuantizedImage:
    """Per-pixel, per-channel bin indices of an RGB uint8 image (once per frame)."""
    if 256 % bins:
        raise ValueError(f"bins must divide 256, got {bins}")
    h, w = image.shape[:2]
    q = np.asarray(image, np.uint8).reshape(-1, 3) // (256 // bins)
    planes = np.empty((3, h * w + 1), np.int32)
    planes[:, :-1] = q.T
    planes[:, -1] = bins
    planes += (np.arange(3, dtype=np.int32) * (bins + 1))[:, None]
    return QuantizedImage(planes, h, w, bins)


@functools.lru_cache(maxsize=16)
def _lattice(grid: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``grid x grid`` lattice in [-0.5, 0.5) (u, v offsets, row-major), read-only."""
    f = (np.arange(grid) + 0.5) / grid - 0.5
    fu, fv = (a.ravel() for a in np.meshgrid(f, f))
    fu.setflags(write=False)
    fv.setflags(write=False)
    return fu, fv


def _grid_uv(states: np.ndarray, patches: np.ndarray, grid: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """``u``, ``v`` ``(N, P, grid*grid)`` of :func:`patch_grid`."""
    x = np.asarray(states, dtype=np.float64)
    x = x[None] if x.ndim == 1 else x
    P = np.asarray(patches, dtype=np.float64)
    fu, fv = _lattice(grid)
    s = x[:, 2, None]                                      # (N, 1)
    u = (x[:, 0, None] + s * P[:, 0])[..., None] + (s * P[:, 2])[..., None] * fu
    v = (x[:, 1, None] + s * P[:, 1])[..., None] + (s * P[:, 3])[..., None] * fv
    return u, v


def patch_grid(states: np.ndarray, patches: np.ndarray, grid: int) -> np.ndarray:
    """Sample positions ``(N, P, grid*grid, 2)`` (u, v) of every patch of every state."""
    return np.stack(_grid_uv(states, patches, grid), axis=-1)


def patch_counts(qimage: QuantizedImage, states: np.ndarray, patches: np.ndarray,
                 grid: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Bin counts ``(N, P, 3, bins)`` of every patch of every state and the number of samples
    on the image ``(N, P)`` (:func:`patch_histograms` before normalising), in one compiled
    pass (:func:`patch_counts_kernel`; :func:`patch_counts_numpy` is the array form)."""
    x = np.asarray(states, dtype=np.float64)
    fu, fv = _lattice(grid)
    counts, total = patch_counts_kernel(qimage.planes, qimage.height, qimage.width,
                                        qimage.bins, np.ascontiguousarray(np.atleast_2d(x)),
                                        np.ascontiguousarray(patches, np.float64), fu, fv)
    return counts[..., :qimage.bins], total


def patch_counts_numpy(qimage: QuantizedImage, states: np.ndarray, patches: np.ndarray,
                       grid: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """:func:`patch_counts` in array operations (its reference in tests)."""
    u, v = _grid_uv(states, patches, grid)  # (N, P, S)
    n, p = u.shape[:2]
    h, w, bins = qimage.height, qimage.width, qimage.bins
    col = np.floor(u + 0.5).astype(np.int64)
    row = np.floor(v + 0.5).astype(np.int64)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    flat = np.where(inside, row * w + col, h * w)  # off the image: the sentinel
    stride = 3 * (bins + 1)
    base = (np.arange(n * p).reshape(n, p, 1) * stride).astype(np.int32)
    ids = np.take(qimage.planes, flat, axis=1) + base   # (3, N, P, S): one gather
    counts = np.bincount(ids.ravel(), minlength=n * p * stride)
    return counts.reshape(n, p, 3, bins + 1)[..., :bins], inside.sum(axis=-1)


def patch_histograms(qimage: QuantizedImage, states: np.ndarray, patches: np.ndarray,
                     grid: int = 8) -> np.ndarray:
    """Normalised histograms ``(N, P, 3, bins)`` of every patch of every state.

    A pixel at integer ``(i, j)`` covers ``[i - 0.5, i + 0.5)``; samples off the image are
    dropped.
    """
    counts, total = patch_counts(qimage, states, patches, grid)
    total = total[..., None, None].astype(np.float64)
    return np.divide(counts, total, out=np.zeros(counts.shape), where=total > 0)


def patch_color_log_likelihood(qimage: QuantizedImage, states: np.ndarray,
                               patches: np.ndarray, refs: np.ndarray, sigma: float,
                               grid: int = 8) -> np.ndarray:
    """:func:`color_log_likelihood` of the patches' :func:`patch_histograms` (unit weights)
    straight from the bin counts: with ``h_b = n_b / n``, the Bhattacharyya coefficient is
    ``sum_b sqrt(n_b) sqrt(ref_b) / sqrt(n)`` -- one product with the references' square
    roots, no normalised histogram; ``D^2 = 1 - BC`` (eq. 6 squares the distance). Equal to
    the two-step form to rounding; the counts in one compiled pass over the particles
    (:func:`patch_bhattacharyya`; :func:`patch_color_log_likelihood_numpy` is the array
    form)."""
    patches, refs = np.asarray(patches, np.float64), np.asarray(refs, np.float64)
    if refs.shape != (len(patches), 3, qimage.bins):
        raise ValueError(f"refs has shape {refs.shape}; the patches and image need "
                         f"{(len(patches), 3, qimage.bins)}")
    fu, fv = _lattice(grid)
    bc = patch_bhattacharyya(qimage.planes, qimage.height, qimage.width, qimage.bins,
                             np.ascontiguousarray(np.atleast_2d(states), np.float64),
                             np.ascontiguousarray(patches, np.float64),
                             np.sqrt(np.ascontiguousarray(refs, np.float64)), fu, fv)
    d2 = np.clip(1.0 - bc, 0.0, 1.0)
    return -d2.sum(axis=(1, 2)) / (2.0 * sigma * sigma)                 # Menezes eq. 6


def patch_color_log_likelihood_numpy(qimage: QuantizedImage, states: np.ndarray,
                                     patches: np.ndarray, refs: np.ndarray, sigma: float,
                                     grid: int = 8) -> np.ndarray:
    """:func:`patch_color_log_likelihood` in array operations (its reference in tests)."""
    counts, total = patch_counts_numpy(qimage, states, patches, grid)
    root_ref = np.sqrt(np.asarray(refs, np.float64))                     # (P, 3, bins)
    bc = np.einsum("npcb,pcb->npc", np.sqrt(counts), root_ref)
    with np.errstate(divide="ignore"):
        bc *= np.where(total > 0, 1.0 / np.sqrt(total), 0.0)[..., None]   # empty: D = 1
    d2 = np.clip(1.0 - bc, 0.0, 1.0)
    return -d2.sum(axis=(1, 2)) / (2.0 * sigma * sigma)                 # Menezes eq. 6


def bhattacharyya(h: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``D = sqrt(1 - sum_b sqrt(h_b ref_b))`` over the last axis (normalised histograms);
    broadcasting ``h (..., B)`` against ``ref``. An empty histogram is at distance 1."""
    bc = np.sum(np.sqrt(np.asarray(h, np.float64) * np.asarray(ref, np.float64)), axis=-1)
    return np.sqrt(np.clip(1.0 - bc, 0.0, 1.0))


def color_log_likelihood(hists: np.ndarray, refs: np.ndarray, sigma: float,
                         weights: np.ndarray | float = 1.0) -> np.ndarray:
    """Menezes eq. 6: ``log p(z^C|x) = -sum_c sum_p lambda_pc D^2 / (2 sigma_c^2)``.

    ``hists (N, P, 3, B)``, ``refs (P, 3, B)``, ``weights`` lambda ``(P, 3)`` or a scalar.
    """
    D = bhattacharyya(hists, refs[None])  # (N, P, 3)
    lam = np.broadcast_to(np.asarray(weights, np.float64), D.shape[1:])
    return -np.sum(lam * D * D, axis=(1, 2)) / (2.0 * sigma * sigma)  # Menezes eq. 6


def update_reference(ref: np.ndarray, observed: np.ndarray, kappa: float | np.ndarray
                     ) -> np.ndarray:
    """Menezes eq. 13: ``(1 - kappa) h_ref + kappa h_E[x]``; ``kappa`` per patch ``(P,)``
    (Table 4: 0.1 head, 0.05 torso) or one value. Patches observed empty keep the reference."""
    ref, obs = np.asarray(ref, np.float64), np.asarray(observed, np.float64)
    k = np.asarray(kappa, np.float64).reshape(-1, *([1] * (ref.ndim - 1))) if np.ndim(
        kappa) else np.float64(kappa)
    seen = obs.sum(axis=-1, keepdims=True) > 0
    return np.where(seen, (1.0 - k) * ref + k * obs, ref)  # Menezes eq. 13


@njit
def _count_patch(planes, height, width, off, u0, v0, su, sv, fu, fv, counts):
    """Bin counts ``counts (3, bins + 1)`` (overwritten) of the samples ``(u0 + su fu, v0 + sv
    fv)`` on the image (nearest pixel; samples off it, or not finite, dropped); returns their
    number."""
    counts[:] = 0
    total = 0
    for k in range(fu.shape[0]):
        col = np.floor(u0 + su * fu[k] + 0.5)
        row = np.floor(v0 + sv * fv[k] + 0.5)
        if not (0.0 <= col < width and 0.0 <= row < height):
            continue
        total += 1
        flat = int(row) * width + int(col)
        for c in range(3):
            counts[c, planes[c, flat] - c * off] += 1
    return total


@njit
def patch_counts_kernel(planes, height, width, bins, states, patches, fu, fv):
    """:func:`patch_counts` compiled: counts ``(N, P, 3, bins + 1)`` (the last bin unused)
    and samples on the image ``(N, P)``."""
    N, P = states.shape[0], patches.shape[0]
    counts = np.zeros((N, P, 3, bins + 1), np.int64)
    total = np.zeros((N, P), np.int64)
    for i in range(N):
        s = states[i, 2]
        for p in range(P):
            total[i, p] = _count_patch(planes, height, width, bins + 1,
                                       states[i, 0] + s * patches[p, 0],
                                       states[i, 1] + s * patches[p, 1], s * patches[p, 2],
                                       s * patches[p, 3], fu, fv, counts[i, p])
    return counts, total


@njit
def patch_bhattacharyya(planes, height, width, bins, states, patches, root_ref, fu, fv):
    """The Bhattacharyya coefficients ``(N, P, 3)`` of every patch of every state (``(u, v,
    s)``, patches ``(P, 4)`` in patch units) with the references (their square roots
    ``root_ref (P, 3, bins)``), from the bin counts on the ``fu``, ``fv`` lattice: ``sum_b
    sqrt(n_b ref_b) / sqrt(n)``, 0 for a patch wholly off the image (the counting of
    :func:`patch_counts`: nearest pixel, samples off the image dropped)."""
    N, P, S = states.shape[0], patches.shape[0], fu.shape[0]
    out = np.zeros((N, P, 3))
    counts = np.zeros((3, bins + 1), np.int64)
    root = np.sqrt(np.arange(S + 1).astype(np.float64))     # sqrt of every possible count
    for i in range(N):
        s = states[i, 2]
        for p in range(P):
            total = _count_patch(planes, height, width, bins + 1,
                                 states[i, 0] + s * patches[p, 0],
                                 states[i, 1] + s * patches[p, 1], s * patches[p, 2],
                                 s * patches[p, 3], fu, fv, counts)
            if total == 0:
                continue
            norm = 1.0 / root[total]
            for c in range(3):
                bc = 0.0
                for q in range(bins):
                    bc += root[counts[c, q]] * root_ref[p, c, q]
                out[i, p, c] = bc * norm
    return out
