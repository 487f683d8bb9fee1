"""Zero-mean normalised cross-correlation (Ude eq. 10) for the stereo matcher, and the images
it reads.

For colour images the paper's eq. 10 treats each pixel as a colour vector: the covariance is the
sum over the box of dot products of mean-free colour vectors (per-channel means), the variance the
sum of squared norms; the ``1/(n-1)`` factors cancel. This is OpenCV's multichannel
``TM_CCOEFF_NORMED``: for a score map over a 2-D window call ``cv2.matchTemplate``. Two batched
forms stay hand-written, because the matcher needs what ``cv2.matchTemplate`` does not offer:

* :func:`zncc_strips`: many targets' one-row strips in a few array operations (2.3x faster than
  one ``cv2.matchTemplate`` per strip, ``benchmarks/peers_zncc.py``);
* :func:`zncc_windows`: each template against a few windows resampled at sub-sample offsets
  along its epipolar line (not a pixel grid, so no ``cv2.matchTemplate`` call covers them).

Both are tested against ``cv2.matchTemplate``. Flat (zero-variance) windows or templates score
0, never NaN.
"""

from __future__ import annotations

import math

import cv2
import numpy as np


def _center_channels(X: np.ndarray, integers: bool) -> None:
    """``X -= X.mean(axis=-2, keepdims=True)`` in place (the same numbers), one channel at a
    time: numpy broadcasts over the interleaved channels with 3-element inner loops."""
    mean = _channel_means(X, integers)
    for c in range(X.shape[-1]):
        X[..., c] -= mean[..., c]


def _channel_means(X: np.ndarray, integers: bool) -> np.ndarray:
    """``X.mean(axis=-2, keepdims=True)`` (per-channel means of ``(..., k, C)``), the same
    numbers. ``integers``: ``X`` (float32 or float64) holds uint8 image values, so its sums
    are exact in any order (below 2^24) and one matrix product computes them - ~10x faster than
    numpy's reduction over the strided axis. The division is numpy's (by an ``intp`` count, in
    float64)."""
    n = X.shape[-2]
    if not integers or n * 255 >= 2**24:
        return X.mean(axis=-2, keepdims=True)
    s = np.matmul(np.ones(n, X.dtype), X)[..., None, :]
    np.true_divide(s, np.intp(n), out=s, casting="unsafe")
    return s


def zncc_strips(strips: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """Batched ZNCC of ``templates (n, h, w, C)`` along ``strips (n, h, Ws, C)`` of equal height.

    Row ``i`` of the result ``(n, Ws - w + 1)`` equals ``cv2.matchTemplate(strips[i],
    templates[i], TM_CCOEFF_NORMED)[0]`` (float32 products, ~1e-6 of a score); all strips are
    processed by the same few array operations (stereo, one strip per target).
    # Ude eq. 10
    """
    n, h, Ws, C = strips.shape
    w = templates.shape[2]
    ow = Ws - w + 1
    T = templates.reshape(n, h * w, C).astype(np.float64)
    _center_channels(T, templates.dtype == np.uint8)
    var_T = np.einsum("nkc,nkc->n", T, T)
    S32 = np.ascontiguousarray(strips, dtype=np.float32)
    es = S32.itemsize
    V = np.ndarray((n, ow, h, w * C), np.float32, S32, 0,
                   (h * Ws * C * es, C * es, Ws * C * es, es)).reshape(n, ow, h * w * C)
    t32 = T.reshape(n, h, w * C).astype(np.float32).reshape(n, h * w * C, 1)
    num = (V @ t32)[..., 0].astype(np.float64)
    Sd = strips.astype(np.float64)
    cs = np.zeros((n, Ws + 1, 2 * C))
    sq = (np.square(Sd).sum(1) if strips.dtype == np.uint8  # exact sums of integers
          else np.einsum("nhwc,nhwc->nwc", Sd, Sd))
    np.cumsum(np.concatenate([Sd.sum(1), sq], 2), 1, out=cs[:, 1:])
    win = cs[:, w:] - cs[:, :-w]  # (n, ow, 2C): per-channel window sums of S and S^2
    var_S = (win[..., C:] - win[..., :C] * win[..., :C] / (h * w)).sum(2)
    den2 = var_S * var_T[:, None]
    ok = (var_S > 1e-10 * (win[..., C:].sum(2) + 1e-300)) & (var_T[:, None] > 1e-10)
    out = np.zeros((n, ow))
    np.divide(num, np.sqrt(np.where(ok, den2, 1.0)), out=out, where=ok)
    return np.clip(out, -1.0, 1.0)


def zncc_windows(windows: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """ZNCC of ``templates (n, h, w, C)`` with ``windows (n, m, h, w, C)`` of their size:
    ``(n, m)`` (row ``i``: template ``i`` against its ``m`` candidate windows). For a few
    candidates per template (the stereo matcher's fine sub-sample search). Products in float32
    on mean-free values (relative error ~1e-6).  # Ude eq. 10
    """
    n, m, h, w, C = windows.shape
    k = h * w
    T = templates.reshape(n, k, C).astype(np.float32)
    _center_channels(T, templates.dtype == np.uint8)  # per-channel means
    S = windows.reshape(n, m, k, C).astype(np.float32)
    _center_channels(S, windows.dtype == np.uint8)
    S = S.reshape(n, m, k * C)
    num = (S @ T.reshape(n, k * C, 1))[..., 0].astype(np.float64)
    var_T = np.square(T).sum(axis=(1, 2), dtype=np.float64)
    var_S = np.square(S).sum(axis=2, dtype=np.float64)
    den2 = var_S * var_T[:, None]
    ok = den2 > 1e-12 * (1.0 + den2.max(initial=0.0))
    out = np.zeros((n, m))
    np.divide(num, np.sqrt(np.where(ok, den2, 1.0)), out=out, where=ok)
    return np.clip(out, -1.0, 1.0)


def closed_posterior(post: np.ndarray, radius: int) -> np.ndarray:
    """Grey-level morphological closing -- dilation (max filter), then erosion (min filter)
    (Serra, *Image Analysis and Mathematical Morphology*, 1982, ch. XII; Gonzalez & Woods,
    *Digital Image Processing*, 3rd ed., eq. 9.2-5) -- of a posterior image ``post (h, w)``
    with a ``(2 radius + 1)^2`` square, the border replicated; ``radius`` 0: ``post`` itself.

    Why: a colour table decides each pixel alone, and the camera's pixel noise moves pixels of
    a colour near a bin the table cut (a shirt of nearly the skin's colour claimed the bins both
    share) across the bin's edge independently in each eye, so the colour mask of a skin blob
    becomes a speckle of holes that differ between the eyes -- and the stereo template matched
    the speckle. Closing fills holes narrower than the square inside the blob and keeps its
    outline (the cue the template matches) and every part at least as wide as the square;
    isolated look-alike pixels outside it stay single pixels.
    """
    if radius <= 0:
        return post
    k = np.ones((2 * radius + 1,) * 2, np.uint8)
    return cv2.erode(cv2.dilate(post, k, borderType=cv2.BORDER_REPLICATE), k,
                     borderType=cv2.BORDER_REPLICATE)


class Prefiltered:
    """An image read with ``cv2.remap`` (bilinear, replicated border), anti-aliased for samples
    spaced ``spacing`` px apart, optionally colour-masked (``lut``: each pixel times its
    probability ``p / (p + 1)`` of having the target's colour, at full resolution first, the
    probability image closed by a square of half-width ``closing`` px first,
    :func:`closed_posterior`).

    Only the crop the requested samples need is prepared (and kept for later reads inside it):
    box-averaged by the integer factor ``k = max(1, floor(spacing / 1.5))`` (an exact
    ``INTER_AREA`` resize, cheap) and blurred by ``max(sigma, spacing / (2 k))`` of its own
    pixels (OpenCV's fast 3x3 kernel up to 0.85), so the total smoothing is about half the
    sample spacing. ``sigma <= 0``: plain bilinear reads of the image.
    """

    def __init__(self, image: np.ndarray, sigma: float, spacing: float = 1.0, lut=None,
                 closing: int = 0):
        self.image, self.sigma, self.lut, self.closing = image, float(sigma), lut, int(closing)
        self.k = max(1, math.floor(spacing / 1.5))
        self.blur = max(self.sigma, spacing / (2.0 * self.k))
        self.ksize = 3 if self.blur <= 0.85 else 2 * math.ceil(2.5 * self.blur) + 1
        self._box: tuple[int, int, int, int] | None = None
        self._crop: np.ndarray | None = None

    def remap(self, mx: np.ndarray, my: np.ndarray, bounds=None) -> np.ndarray:
        """Bilinear reads at raw pixels ``(mx, my)`` (float32 maps, or converted); ``bounds``:
        their ``(min x, max x, min y, max y)`` when the caller has them (batched reads)."""
        if mx.dtype != np.float32:
            mx, my = mx.astype(np.float32), my.astype(np.float32)
        if self.sigma <= 0.0:
            return cv2.remap(self.image, mx, my, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
        H, W = self.image.shape[:2]
        k = self.k
        r = (self.ksize // 2 + 2) * k
        x_lo, x_hi, y_lo, y_hi = bounds if bounds is not None else (
            float(mx.min()), float(mx.max()), float(my.min()), float(my.max()))
        box = (min(max(math.floor(x_lo) - r, 0), W - 1),
               max(min(math.ceil(x_hi) + r, W - 1), 0),
               min(max(math.floor(y_lo) - r, 0), H - 1),
               max(min(math.ceil(y_hi) + r, H - 1), 0))
        b = self._box
        if b is None or not (b[0] <= box[0] and box[1] <= b[1] and b[2] <= box[2]
                             and box[3] <= b[3]):
            x0, y0 = box[0], box[2]
            w = max((box[1] - x0 + 1) // k, 1) * k  # whole k x k cells inside the image
            h = max((box[3] - y0 + 1) // k, 1) * k
            crop = self.image[y0:y0 + h, x0:x0 + w]
            if self.lut is not None:  # colour mask, at full resolution, back to uint8
                post = closed_posterior(self.lut.posterior(crop), self.closing)
                crop = cv2.multiply(crop, cv2.merge([post] * 3),
                                    dtype=cv2.CV_8U)
            if k > 1:
                crop = cv2.resize(crop, (crop.shape[1] // k, crop.shape[0] // k),
                                  interpolation=cv2.INTER_AREA)
            self._box = (x0, x0 + crop.shape[1] * k - 1, y0, y0 + crop.shape[0] * k - 1)
            self._crop = cv2.GaussianBlur(crop, (self.ksize,) * 2, self.blur,
                                          borderType=cv2.BORDER_REPLICATE)
        x0, _, y0, _ = self._box
        if k == 1:  # (m - x0 - 0) / 1 without the exact no-ops
            return cv2.remap(self._crop, mx - np.float32(x0), my - np.float32(y0),
                             cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        off = np.float32(0.5 * (k - 1))  # a reduced pixel's centre in full-resolution pixels
        return cv2.remap(self._crop, (mx - np.float32(x0) - off) / np.float32(k),
                         (my - np.float32(y0) - off) / np.float32(k), cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)


def read_batch(sources: list[Prefiltered], mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """Job ``r``'s samples ``(mx[r], my[r])`` (raw pixels) from ``sources[r]``, stacked: one
    float32 conversion and one min/max per axis for all jobs."""
    n = len(sources)
    mx, my = mx.astype(np.float32), my.astype(np.float32)
    fx, fy = mx.reshape(n, -1), my.reshape(n, -1)
    bounds = zip(fx.min(1).tolist(), fx.max(1).tolist(), fy.min(1).tolist(),
                 fy.max(1).tolist(), strict=True)
    return np.stack([src.remap(mx[r], my[r], b)
                     for r, (src, b) in enumerate(zip(sources, bounds, strict=True))])
