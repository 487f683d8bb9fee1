"""Zero-mean normalised cross-correlation (Ude eq. 10) and sub-pixel peak refinement.

For colour images the paper's eq. 10 treats each pixel as a colour vector: the covariance is the
sum over the box of dot products of mean-free colour vectors (per-channel means), the variance the
sum of squared norms; the ``1/(n-1)`` factors cancel. This equals OpenCV's multichannel
``TM_CCOEFF_NORMED``, against which it is tested, but is computed independently here: the
numerator is one ``cv2.filter2D`` correlation (channels interleaved along the row, so one call
covers all channels) or, for maps of few rows, float32 matrix-vector products on strided window
views; window sums come from integral images or column cumulative sums. :func:`zncc_strips`
batches the one-row case over many strips (stereo: one strip per target). Flat (zero-variance)
windows or templates score 0, never NaN.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

#: Output maps with at most this many rows use strided row products instead of cv2.filter2D.
_ROW_PATH_MAX_ROWS = 4


def _numerator(S: np.ndarray, Tz: np.ndarray, oh: int, ow: int) -> np.ndarray:
    """``sum_{dy,dx,c} Tz[dy,dx,c] * S[y+dy, x+dx, c]`` for every valid ``(y, x)``: ``(oh, ow)``.

    Channels are interleaved along the row, so a (h, w*C) kernel on the (H, W*C) image covers all
    channels at once (output columns at multiples of C). Few output rows (stereo strips): one
    float32 matrix-vector product per row on a strided window view; otherwise ``cv2.filter2D``.
    """
    H, W, C = S.shape
    h, w = Tz.shape[:2]
    S2 = np.ascontiguousarray(S, dtype=np.float32).reshape(H, W * C)
    t2 = np.ascontiguousarray(Tz, dtype=np.float32).reshape(h, w * C)
    if oh <= _ROW_PATH_MAX_ROWS:
        flat = S2.ravel()
        es = flat.itemsize
        tv = t2.ravel()
        out = np.empty((oh, ow))
        for y in range(oh):
            V = np.lib.stride_tricks.as_strided(flat[y * W * C:], shape=(ow, h, w * C),
                                                strides=(C * es, W * C * es, es), writeable=False)
            out[y] = V.reshape(ow, h * w * C) @ tv
        return out
    full = cv2.filter2D(S2, cv2.CV_32F, t2, anchor=(0, 0), borderType=cv2.BORDER_CONSTANT)
    return full[:oh, : ow * C : C].astype(np.float64)


def zncc_map(search: np.ndarray, template: np.ndarray) -> np.ndarray:
    """ZNCC of ``template`` (h, w[, C]) at every valid position of ``search`` (H, W[, C]).

    Returns ``(H - h + 1, W - w + 1)`` float64 scores in [-1, 1]; entry ``[y, x]`` is the template
    with its top-left pixel on ``search[y, x]`` (as ``cv2.matchTemplate``). Products are float32
    (relative error ~1e-6 of the score); window sums exact (float64 integral images).
    # Ude eq. 10
    """
    S = np.asarray(search)
    T = np.asarray(template)
    if S.ndim == 2:
        S, T = S[..., None], T[..., None]
    H, W, C = S.shape
    h, w = T.shape[:2]
    if T.ndim != 3 or T.shape[2] != C or h > H or w > W or h < 1 or w < 1:
        raise ValueError(f"template {template.shape} does not fit search region {search.shape}")
    n = h * w
    oh, ow = H - h + 1, W - w + 1
    Tz = T.reshape(n, C).astype(np.float64)
    Tz -= Tz.mean(axis=0)  # mean-free template, per channel
    var_T = float(np.einsum("ij,ij->", Tz, Tz))
    if var_T <= 1e-10 * (1.0 + float(np.abs(Tz).max())):
        return np.zeros((oh, ow))  # flat template
    if oh == 1:  # a strip exactly as tall as the template (stereo): column sums suffice
        return _zncc_row(S, Tz.reshape(h, w, C), var_T)
    # sum of Tz is 0 per channel, so the window mean drops out of the numerator
    num = _numerator(S, Tz.reshape(h, w, C), oh, ow)
    Sd = S if S.dtype in (np.uint8, np.float64) else S.astype(np.float64)
    ii, ii2 = cv2.integral2(Sd, sdepth=cv2.CV_64F, sqdepth=cv2.CV_64F)
    ii, ii2 = ii.reshape(H + 1, W + 1, C), ii2.reshape(H + 1, W + 1, C)

    def box(I):
        return I[h:, w:] - I[:-h, w:] - I[h:, :-w] + I[:-h, :-w]

    s1, s2 = box(ii), box(ii2)
    var_S = (s2 - s1 * s1 / n).sum(axis=-1)
    ok = var_S > 1e-10 * (s2.sum(axis=-1) + 1e-300)  # flat windows score 0
    out = np.zeros((oh, ow))
    np.divide(num, np.sqrt(np.where(ok, var_S, 1.0) * var_T), out=out, where=ok)
    return np.clip(out, -1.0, 1.0)


def _zncc_row(S: np.ndarray, Tz: np.ndarray, var_T: float) -> np.ndarray:
    """:func:`zncc_map` for ``H == h`` (one output row) with few array operations."""
    H, W, C = S.shape
    h, w = Tz.shape[:2]
    ow = W - w + 1
    Sd = S.astype(np.float64)
    cs = np.zeros((W + 1, 2 * C))
    np.cumsum(np.concatenate([Sd.sum(0), np.einsum("hwc,hwc->wc", Sd, Sd)], 1), 0, out=cs[1:])
    win = cs[w:] - cs[:-w]  # (ow, 2C): per-channel window sums of S and S^2
    var_S = (win[:, C:] - win[:, :C] * win[:, :C] / (h * w)).sum(1)
    num = _numerator(S, Tz, 1, ow)[0]
    ok = var_S > 1e-10 * (win[:, C:].sum(1) + 1e-300)
    out = np.zeros(ow)
    np.divide(num, np.sqrt(np.where(ok, var_S, 1.0) * var_T), out=out, where=ok)
    return np.clip(out, -1.0, 1.0)[None]


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

    Row ``i`` of the result ``(n, Ws - w + 1)`` equals ``zncc_map(strips[i], templates[i])[0]``;
    all strips are processed by the same few array operations (stereo, one strip per target).
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


def parabola_offset(f_minus: float, f_0: float, f_plus: float) -> float:
    """Sub-sample offset of the vertex of the parabola through (-1, f-), (0, f0), (1, f+).

    Clipped to [-0.5, 0.5]; 0 when the three samples do not bracket a maximum.
    """
    curv = f_minus - 2.0 * f_0 + f_plus
    if not curv < 0.0:
        return 0.0
    return float(np.clip(0.5 * (f_minus - f_plus) / curv, -0.5, 0.5))


def subpixel_peak(score: np.ndarray, mask: np.ndarray | None = None) -> tuple[float, float, float]:
    """Maximum of a score map refined per axis by parabola fits: ``(x, y, peak score)``.

    ``x`` is the column, ``y`` the row (map coordinates). ``mask`` (bool, same shape) restricts
    the integer search; neighbours used for the fit need not be in the mask.
    """
    s = np.where(mask, score, -np.inf) if mask is not None else score
    iy, ix = np.unravel_index(int(np.argmax(s)), s.shape)
    best = float(score[iy, ix])
    dx = dy = 0.0
    if 0 < ix < score.shape[1] - 1:
        dx = parabola_offset(score[iy, ix - 1], best, score[iy, ix + 1])
    if 0 < iy < score.shape[0] - 1:
        dy = parabola_offset(score[iy - 1, ix], best, score[iy + 1, ix])
    return ix + dx, iy + dy, best


class Prefiltered:
    """An image read with ``cv2.remap`` (bilinear, replicated border), anti-aliased for samples
    spaced ``spacing`` px apart, optionally colour-masked (``lut``: each pixel times its
    probability ``p / (p + 1)`` of having the target's colour, at full resolution first).

    Only the crop the requested samples need is prepared (and kept for later reads inside it):
    box-averaged by the integer factor ``k = max(1, floor(spacing / 1.5))`` (an exact
    ``INTER_AREA`` resize, cheap) and blurred by ``max(sigma, spacing / (2 k))`` of its own
    pixels (OpenCV's fast 3x3 kernel up to 0.85), so the total smoothing is about half the
    sample spacing. ``sigma <= 0``: plain bilinear reads of the image.
    """

    def __init__(self, image: np.ndarray, sigma: float, spacing: float = 1.0, lut=None):
        self.image, self.sigma, self.lut = image, float(sigma), lut
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
                crop = cv2.multiply(crop, cv2.merge([self.lut.posterior(crop)] * 3),
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
