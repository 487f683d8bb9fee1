"""The shape cue (Menezes sec. 4.1.1): distances from template points to image edges.

Per frame, once (cost independent of the number of particles): Canny edges and their
distance transform (OpenCV). Per particle, vectorised over all particles' contour points:

* eq. 2 -- :func:`normal_edge_distance`: for each model point, the nearest edge *along its
  normal* (searched over +-``search_px``), ``D = mean_j |x(j) - z(j)|``; a point with no edge
  in reach counts ``search_px``.
* eq. 3 -- :func:`dt_distance`: ``D = mean_j I_DT(x(j))``, the distance transform sampled
  (bilinearly) at all points in one ``cv2.remap`` gather; points off the image count ``cap``.

The likelihood has the form ``p(z^S|x) ∝ exp(-lambda_s D^2 / (2 sigma_s^2))`` (eq. 2; the
printed equation lacks the minus sign). Table 3's sigma_s = 36 for N_p = 30 points reads as a
*sum* of distances (36/30 = 1.2 px per point, next to Table 4's 1.5 for the mean): pass
``reduce="sum"`` for that reading.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from humimic.maths.jit import njit

DT_CAP_PX = 30.0
"""Distance given to points off the image and the largest distance-transform value used."""


@dataclass(frozen=True)
class EdgeMaps:
    """One frame's edge image (uint8 0/255) and its distance transform (float32, px)."""

    edges: np.ndarray
    dt: np.ndarray


def grey(image: np.ndarray) -> np.ndarray:
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


@contextmanager
def without_ipp() -> Iterator[None]:
    """OpenCV's own code instead of Intel's IPP for the calls inside (OpenCV's switch is per
    thread), restored after. For calls whose IPP path rounds differently by the memory address
    of the output, which the Python binding allocates wherever numpy's heap puts it: the same
    seed would give other bits in another process."""
    use = cv2.ipp.useIPP()
    cv2.ipp.setUseIPP(False)
    try:
        yield
    finally:
        cv2.ipp.setUseIPP(use)


def distance_transform(edges: np.ndarray, cap: float = DT_CAP_PX,
                       mask: int = cv2.DIST_MASK_PRECISE) -> np.ndarray:
    """Euclidean distance (px) of every pixel to the nearest edge pixel, capped at ``cap``
    (``cv2.distanceTransform``, exact L2; ``mask=cv2.DIST_MASK_5``: the 5 x 5 chamfer
    approximation, within 0.6 px below 30 px and half the time). An image without edges is
    ``cap`` everywhere.

    The exact transform runs without IPP: IPP's result moved by an ulp (1e-7 relative) on a
    tenth of the pixels with the output's address modulo 32 (a 51 x 73 GEST cue box: 7 results
    over 16 offsets), so GEST's estimates differed across processes; OpenCV's own exact
    transform is the float32 of the exact distance and no slower (47 against 64 us a box,
    CPU time)."""
    if not edges.any():
        return np.full(edges.shape, cap, np.float32)
    free = cv2.compare(edges, 0, cv2.CMP_EQ)  # 255 off the edges
    if mask == cv2.DIST_MASK_PRECISE:
        with without_ipp():
            dt = cv2.distanceTransform(free, cv2.DIST_L2, mask)
    else:  # the chamfer masks' IPP paths measured address-independent
        dt = cv2.distanceTransform(free, cv2.DIST_L2, mask)
    return cv2.threshold(dt, float(cap), 0.0, cv2.THRESH_TRUNC)[1]


def canny(image: np.ndarray, low: float = 50.0, high: float = 150.0,
          blur_sigma: float = 1.0) -> np.ndarray:
    """Canny edges (uint8 0/255) of an RGB or grey uint8 image, after a small Gaussian blur
    against pixel noise."""
    g = grey(image)
    if blur_sigma > 0:
        g = cv2.GaussianBlur(g, (0, 0), blur_sigma)
    return cv2.Canny(g, low, high, L2gradient=True)


def colour_canny(image: np.ndarray, low: float = 50.0, high: float = 150.0,
                 blur_sigma: float = 1.0) -> np.ndarray:
    """Canny edges (uint8 0/255) of an RGB uint8 image on its colour gradient: per pixel, the
    Sobel gradient of the channel where it is strongest (Di Zenzo's maximum-channel
    approximation), fed to OpenCV's hysteresis. Finds boundaries between colours of equal
    brightness (skin against a grey wall) that :func:`canny` on the grey image misses; on a
    grey image (equal channels) it is :func:`canny`. The gradient of the strongest channel:
    :func:`strongest_channel_sobel`."""
    if image.ndim == 2:
        return canny(image, low, high, blur_sigma)
    img = cv2.GaussianBlur(image, (0, 0), blur_sigma) if blur_sigma > 0 else image
    gx, gy = strongest_channel_sobel(img)
    return cv2.Canny(gx, gy, low, high, L2gradient=True)


def strongest_channel_sobel(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of a ``(h, w, C)`` uint8 image, the 3 x 3 Sobel gradient ``(gx, gy)`` (int16,
    ``cv2.Sobel`` with ``BORDER_REPLICATE``) of the channel where its squared magnitude is
    largest (the first such channel): two ``cv2.Sobel`` calls on all channels at once and one
    compiled selection (:func:`_strongest`), instead of a dozen OpenCV calls on the small cue
    boxes. (A compiled pass doing the Sobel sums as well took 0.31 ms CPU on the 125 x 147
    cue box against 0.15 ms for this, load ~15.)"""
    h, w, nc = image.shape
    dx = cv2.Sobel(image, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    dy = cv2.Sobel(image, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    return _strongest(dx.reshape(h, w, nc), dy.reshape(h, w, nc))


@njit
def _strongest(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of ``(h, w, C)`` int16 gradients, ``(dx, dy)`` of the channel with the largest
    ``dx^2 + dy^2`` (the first on ties), as ``(h, w)`` int16; without branches (a selection per
    channel; three channels unrolled), which the compiler turns into conditional moves."""
    h, w, nc = dx.shape
    gx = np.empty((h, w), np.int16)
    gy = np.empty((h, w), np.int16)
    for y in range(h):
        for x in range(w):
            if nc == 3:
                a0, b0 = np.int32(dx[y, x, 0]), np.int32(dy[y, x, 0])
                a1, b1 = np.int32(dx[y, x, 1]), np.int32(dy[y, x, 1])
                a2, b2 = np.int32(dx[y, x, 2]), np.int32(dy[y, x, 2])
                m0, m1, m2 = a0 * a0 + b0 * b0, a1 * a1 + b1 * b1, a2 * a2 + b2 * b2
                bx = a1 if m1 > m0 else a0
                by = b1 if m1 > m0 else b0
                best = m1 if m1 > m0 else m0
                bx = a2 if m2 > best else bx
                by = b2 if m2 > best else by
            else:
                best, bx, by = np.int32(-1), np.int32(0), np.int32(0)
                for c in range(nc):
                    a, b = np.int32(dx[y, x, c]), np.int32(dy[y, x, c])
                    m = a * a + b * b
                    take = m > best
                    bx = a if take else bx
                    by = b if take else by
                    best = m if take else best
            gx[y, x], gy[y, x] = bx, by
    return gx, gy


def edge_maps(image: np.ndarray, low: float = 50.0, high: float = 150.0,
              blur_sigma: float = 1.0, cap: float = DT_CAP_PX,
              mask: int = cv2.DIST_MASK_PRECISE, colour: bool = False) -> EdgeMaps:
    """:func:`canny` edges (:func:`colour_canny` with ``colour``) and their distance transform
    for an RGB or grey uint8 image."""
    edges = (colour_canny if colour else canny)(image, low, high, blur_sigma)
    return EdgeMaps(edges, distance_transform(edges, cap, mask))


def remap_uv(image: np.ndarray, u: np.ndarray, v: np.ndarray, outside, interpolation: int
             ) -> np.ndarray:
    """``cv2.remap`` of ``image`` at points with coordinates ``u``, ``v`` (same shape, any
    size, up to 33 M points) -> that shape (``+ (C,)`` for a C-channel image). remap's maps
    must be under 32767 wide and high: a longer last axis, or more rows, are laid out in rows
    of 1024."""
    shape = np.shape(u)
    last = shape[-1] if shape else 1
    if 0 < last < 32767 and math.prod(shape[:-1]) < 32767:
        mx = np.asarray(u, np.float32).reshape(-1, last)
        my = np.asarray(v, np.float32).reshape(-1, last)
    else:
        m = math.prod(shape)
        rows = max(1, -(-m // 1024))
        mx = np.full(rows * 1024, -1e6, np.float32)
        my = np.full(rows * 1024, -1e6, np.float32)
        mx[:m], my[:m] = np.ravel(u), np.ravel(v)
        mx, my = mx.reshape(rows, 1024), my.reshape(rows, 1024)
    out = cv2.remap(image, mx, my, interpolation, borderMode=cv2.BORDER_CONSTANT,
                    borderValue=outside)
    m = math.prod(shape)                    # np.prod of a tuple costs ~10 us, an array's
    return out.reshape(mx.size, -1)[:m].reshape(shape + out.shape[2:])


def sample(image: np.ndarray, points: np.ndarray, outside: float,
           nearest: bool = False) -> np.ndarray:
    """Values of a single-channel image at points ``(..., 2)`` (u, v) in one gather (bilinear
    unless ``nearest``); points off the image get ``outside``."""
    pts = np.asarray(points)
    return sample_uv(image, pts[..., 0], pts[..., 1], outside, nearest)


def sample_uv(image: np.ndarray, u: np.ndarray, v: np.ndarray, outside: float,
              nearest: bool = False) -> np.ndarray:
    """:func:`sample` at points given by their coordinates ``u``, ``v`` (same shape; float32
    arrays are used as they are) -> that shape, float64."""
    src = image if image.dtype in (np.uint8, np.float32) else image.astype(np.float32)
    out = remap_uv(src, u, v, float(outside), cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR)
    return out.astype(np.float64)


def _reduce(per_point: np.ndarray, reduce: str) -> np.ndarray:
    if reduce == "mean":
        return per_point.mean(axis=-1)
    if reduce == "sum":
        return per_point.sum(axis=-1)
    raise ValueError(f"reduce must be 'mean' or 'sum', got {reduce!r}")


def dt_distance(dt: np.ndarray, points: np.ndarray, cap: float = DT_CAP_PX,
                reduce: str = "mean") -> np.ndarray:
    """Menezes eq. 3: ``D = (1/N_p) sum_j I_DT(x(j))`` for points ``(N, N_p, 2)`` -> ``(N,)``."""
    return _reduce(sample(dt, points, cap), reduce)  # Menezes eq. 3


def normal_offsets(search_px: int) -> np.ndarray:
    """Offsets ``0, -1, +1, -2, +2, ...`` along the normal: nearest first."""
    k = np.arange(1, search_px + 1)
    return np.concatenate([[0], np.stack([-k, k], axis=1).ravel()]).astype(np.float64)


def least_cost_along_normal(image: np.ndarray, points: np.ndarray, normals: np.ndarray,
                            search_px: int, cost_of_value: np.ndarray) -> np.ndarray:
    """Per point ``(..., 2)``, the least ``|o| + cost_of_value[image(x(j) + o n(j))]`` over
    the offsets ``o`` of :func:`normal_offsets` (a uint8 ``image``, ``cost_of_value`` (256,))
    -> ``points.shape[:-1]``; the probes in float32 read as ``cv2.remap`` with
    ``INTER_NEAREST`` reads them (half to even, off the image 0), in one compiled pass with no
    (offsets x points) temporaries."""
    p = np.asarray(points, np.float32).reshape(-1, 2)
    n = np.asarray(normals, np.float32).reshape(-1, 2)
    cost = np.asarray(cost_of_value, np.float64)
    out = _least_cost(np.ascontiguousarray(image, np.uint8), p, n, _offsets32(search_px),
                      cost, float(cost.min()))
    return out.reshape(np.shape(points)[:-1])


@functools.lru_cache(maxsize=8)
def _offsets32(search_px: int) -> np.ndarray:
    """:func:`normal_offsets` in float32 (read-only: shared between calls)."""
    off = normal_offsets(search_px).astype(np.float32)
    off.flags.writeable = False
    return off


@njit
def _least_cost(image, p, n, off, cost_of_value, least_value_cost):
    """The probe walk of :func:`least_cost_along_normal`; ``off`` ordered by ``|o|``, so the
    walk stops once ``|o| + least_value_cost`` reaches the best cost so far: no later probe
    can cost less (the minimum, hence the result, is the same as over every probe)."""
    h, w = image.shape
    out = np.empty(len(p))
    for j in range(len(p)):
        best = np.inf
        for k in range(len(off)):
            if abs(np.float64(off[k])) + least_value_cost >= best:
                break
            u = p[j, 0] + off[k] * n[j, 0]      # float32, as the probes given to cv2.remap
            v = p[j, 1] + off[k] * n[j, 1]
            value = 0
            if u == u and v == v:               # cv2.remap's INTER_NEAREST: round half to
                iu, iv = np.rint(u), np.rint(v)  # even, outside the image reads 0
                if 0.0 <= iu < w and 0.0 <= iv < h:
                    value = image[int(iv), int(iu)]
            c = abs(np.float64(off[k])) + cost_of_value[value]
            if c < best:
                best = c
        out[j] = best
    return out


def nearest_along_normal(mask: np.ndarray, points: np.ndarray, normals: np.ndarray,
                         search_px: int) -> np.ndarray:
    """Distance (px) from each point to the nearest set pixel of ``mask`` along its normal
    within ``search_px``; ``inf`` where there is none. ``(N, N_p, 2)`` -> ``(N, N_p)``."""
    src = mask if mask.dtype == np.uint8 else (mask > 0).astype(np.uint8)
    return least_cost_along_normal(src, points, normals, search_px, _HIT_COST)


_HIT_COST = np.r_[np.inf, np.zeros(255)]
"""Any set pixel costs nothing beyond its distance; an unset one is no hit."""


def normal_edge_distance(edges: np.ndarray, points: np.ndarray, normals: np.ndarray,
                         search_px: int = 15, reduce: str = "mean") -> np.ndarray:
    """Menezes eq. 2: ``D = (1/N_p) sum_j |x(j) - z(j)|`` with ``z(j)`` the nearest edge on
    the normal through ``x(j)``; no edge within ``search_px`` counts ``search_px``."""
    d = nearest_along_normal(edges, points, normals, search_px)
    return _reduce(np.minimum(d, float(search_px)), reduce)  # Menezes eq. 2


def shape_log_likelihood(D: np.ndarray, sigma: float, weight: float = 1.0) -> np.ndarray:
    """``log p(z^S|x) = -lambda_s D^2 / (2 sigma_s^2)`` (eq. 2, up to a constant)."""
    D = np.asarray(D, dtype=np.float64)
    return -weight * D * D / (2.0 * sigma * sigma)
