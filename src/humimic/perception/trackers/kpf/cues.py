"""Schmidt, Fritsch & Kwolek's image cues (sec. 4), computed once per frame as maps and sampled
at every particle's feature points in one numpy pass. (The likelihood reads the same responses
through :mod:`~humimic.perception.trackers.kpf.cue_costs`, one compiled loop over the projected
limbs; the functions here state the maths and are the reference it is tested against, through
the per-cue kernels of ``tests/_kpf_limb_cues.py``.)

* edge (eqs. 1-2): first derivatives with a non-linear normalisation
  (``g / |g| tanh(|g| / k)``: weak texture edges smoothed away, strong edges saturated at 1);
  response ``|g_y cos a - g_x sin a|`` with ``a`` the limb's image angle, averaged over the
  ``M_E`` boundary points;
* ridge (eqs. 3-4): second derivatives, normalised the same way, on a Gaussian pyramid; the
  level per limb from its image width (``width / 2^mu`` nearest to :data:`RIDGE_WIDTH_PX`, the
  width the pyramid's derivative filter is tuned to), response ``|s^2 xx + c^2 yy - 2 sc xy| -
  |c^2 xx + s^2 yy + 2 sc xy|`` (curvature across the limb minus along it);
* mean colour (eqs. 5-6): the mean RGB (in [0, 1]) over sample points of each of the limb's
  ``B_l`` polygons, L2 distance to the limb's adapted reference (eq. 7, in the tracker);
* skin (eq. 8): the fraction of sample points in a hand's / the head's image ellipse that the
  skin segmentation (the scenario's learned skin colour model, :class:`ColorLUT`, posterior >
  1/2) accepts.

Each cue's response is turned into a *cost* in [0, 1]-ish (0 perfect): ``1 - f`` for edge,
ridge and skin (high response = match), ``f`` for colour (a distance): eq. 9's Gaussian is of
the cost.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.maths.arrays import stack
from humimic.maths.jit import njit
from humimic.perception.cues.color_models import ColorLUT

#: Width (px) of a bright/dark bar that the 3x3 second derivative of the pyramid responds to best.
RIDGE_WIDTH_PX = 4.0


@dataclass(frozen=True)
class CueMaps:
    """One frame's cue maps (float32 images, sampled by :func:`sample`)."""

    gradient: np.ndarray
    """(H, W, 2) normalised ``d/du``, ``d/dv``."""
    ridge: np.ndarray
    """(H_total, W, 4) the pyramid levels one below the other (a zero row after each, zeros
    right of the smaller ones, so a point clipped to a level's ``[-1, H_mu] x [-1, W_mu]``
    never reads its neighbour), channels ``(uu - vv) / 2``, ``uv``, ``(uu + vv) / 2``, 0 of
    the normalised second derivatives (see :func:`ridge_response`)."""
    level_shapes: np.ndarray
    """(levels, 2) (H_mu, W_mu) of the pyramid levels."""
    level_rows: np.ndarray
    """(levels,) the first row of each level in ``ridge``."""
    rgb: np.ndarray
    """(H, W, 3) in [0, 1]."""
    skin: np.ndarray
    """(H, W) 1 where skin."""
    origin: tuple[int, int] = (0, 0)
    """Image pixel ``(u, v)`` of the maps' pixel ``(0, 0)`` (maps of an image region)."""

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the maps."""
        return self.rgb.shape[:2]


    @property
    def grad(self) -> np.ndarray:
        """(2, H, W) normalised ``d/du``, ``d/dv``."""
        return np.moveaxis(self.gradient, -1, 0)


#: cv2.remap's limit on an image or map side.
_REMAP_MAX = 32766


def sample(image: np.ndarray, uv: np.ndarray, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """``image (H, W[, C])`` (float32, C <= 4) at the nearest pixels of points ``uv (N, ..., 2)``
    (pixels, rounded half to even by ``np.rint`` before ``cv2.remap`` sees them as float32),
    0 off the image and at NaN points: ``(N, ..., [C])``. One ``cv2.remap`` pass, no index
    arrays. ``origin``: the image pixel of ``image[0, 0]`` (maps of an image region)."""
    lead, chans = uv.shape[:-1], image.shape[2:]
    n = lead[0] if lead else 1
    m = np.rint(uv).astype(np.float32).reshape(n, -1)
    if origin != (0, 0):   # (u, v) pairs as complex numbers: one scalar subtraction
        m.view(np.complex64)[...] -= np.complex64(complex(*origin))
    m = m.reshape(n, -1, 2)
    if m.size == 0:
        return np.zeros(lead + chans, np.float32)
    if m.shape[1] > _REMAP_MAX:
        m = m.reshape(-1, 1, 2)
    parts = [cv2.remap(image, m[i:i + _REMAP_MAX], None, cv2.INTER_NEAREST,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
             for i in range(0, len(m), _REMAP_MAX)]
    out = parts[0] if len(parts) == 1 else np.concatenate(parts)
    return out.reshape(lead + chans)


def _mean_last(x: np.ndarray) -> np.ndarray:
    """Mean over the last (short) axis as a matrix product (numpy's reductions over a short
    last axis are several times slower)."""
    return x @ np.full(x.shape[-1], 1.0 / x.shape[-1], x.dtype)


def _norm_factor(mag: np.ndarray, k: float) -> np.ndarray:
    """Sidenbladh's non-linear normalisation of derivatives of magnitude ``mag``: the factor
    ``tanh(|g| / k) / |g|`` (weak texture smoothed away, strong edges saturated at 1)."""
    return np.tanh(mag / k) / np.maximum(mag, 1e-6)


def strongest_channel(*planes: np.ndarray) -> list[np.ndarray]:
    """Per pixel, the channel whose derivatives ``planes`` (each ``(H, W, 3)``) have the
    largest squared sum (the first on ties): ``(H, W)`` each. The colour gradient of Dalal &
    Triggs' HOG (the channel of the largest norm): an edge between two colours of equal
    brightness has none in grey. ``(H, W)`` planes are returned as they are. The maths in
    numpy (float32 squared sums in the planes' order); the maps use the compiled
    :func:`_strongest_norm`, tested against this."""
    if planes[0].ndim == 2:
        return list(planes)
    planes = [np.asarray(p, np.float32) for p in planes]
    mag = planes[0] * planes[0]
    for p in planes[1:]:
        mag += p * p
    best = np.argmax(mag, axis=-1)[..., None]
    return [np.take_along_axis(p, best, -1)[..., 0] for p in planes]


def _strongest_norm(*planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`strongest_channel` of the derivative ``planes`` and the norm of the selected
    derivatives, ``sqrt(p0^2 + p1^2 + ...)`` in float32 (``(k, H, W)``, ``(H, W)``)."""
    if planes[0].ndim == 2:
        planes = tuple(p[..., None] for p in planes)
    return _strongest_mag(tuple(np.ascontiguousarray(p, np.float32) for p in planes))


@njit
def _strongest_mag(planes):
    """:func:`strongest_channel`'s selection compiled, with the selected channel's norm (its
    squared sum is the one compared, in the same order; the first channel on ties)."""
    h, w, nc = planes[0].shape
    out = np.empty((len(planes), h, w), np.float32)
    mag = np.empty((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            best, top = 0, np.float32(-1.0)
            for c in range(nc):
                m = planes[0][y, x, c] * planes[0][y, x, c]
                for k in range(1, len(planes)):
                    m += planes[k][y, x, c] * planes[k][y, x, c]
                if m > top:
                    best, top = c, m
            for k in range(len(planes)):
                out[k, y, x] = planes[k][y, x, best]
            mag[y, x] = np.sqrt(top)
    return out, mag


def _tanh_scaled(mag: np.ndarray, k: float) -> np.ndarray:
    """``tanh(mag / k)`` (numpy's float32 tanh: the value :func:`_norm_factor` computes)."""
    t = np.divide(mag, k, dtype=np.float32)
    return np.tanh(t, out=t)


@njit
def _at_least(x, lo):
    """``np.maximum(x, lo)`` of scalars (NaN stays NaN)."""
    return lo if x < lo else x


@njit
def _edge_planes(sel, mag, t, out):
    """``out (H, W, 2)`` = the derivatives ``sel (2, H, W)`` times :func:`_norm_factor`
    ``t / max(mag, 1e-6)`` (float32, as numpy's operations)."""
    eps = np.float32(1e-6)
    for y in range(mag.shape[0]):
        for x in range(mag.shape[1]):
            f = t[y, x] / _at_least(mag[y, x], eps)
            out[y, x, 0] = sel[0, y, x] * f
            out[y, x, 1] = sel[1, y, x] * f


@njit
def _ridge_planes(sel, mag, t, out):
    """``out (H, W, 4)`` = ``(uu - vv) / 2``, ``uv``, ``(uu + vv) / 2``, 0 of the second
    derivatives ``sel (3, H, W)`` times :func:`_norm_factor` (float32, as numpy's
    ``0.5 * (uu - vv) * f``, ...)."""
    eps, half = np.float32(1e-6), np.float32(0.5)
    for y in range(mag.shape[0]):
        for x in range(mag.shape[1]):
            f = t[y, x] / _at_least(mag[y, x], eps)
            uu, uv, vv = sel[0, y, x], sel[1, y, x], sel[2, y, x]
            out[y, x, 0] = half * (uu - vv) * f
            out[y, x, 1] = uv * f
            out[y, x, 2] = half * (uu + vv) * f
            out[y, x, 3] = 0.0


def cue_maps(image: np.ndarray, skin_lut: ColorLUT, levels: int = 3, k_edge: float = 0.15,
             k_ridge: float = 0.05, region: tuple[int, int, int, int] | None = None,
             colour_gradients: bool = False) -> CueMaps:
    """Cue maps of an RGB uint8 image; ``k_edge`` / ``k_ridge`` the normalisation's contrast
    scales (grey levels in [0, 1] per pixel, per pixel^2). ``region`` ``(u0, v0, u1, v1)``:
    only that part of the image (``u0``, ``v0`` multiples of ``2^(levels - 1)`` keep the
    pyramid aligned with the whole image's; the maps equal the whole image's farther than
    :data:`~humimic.perception.trackers.kpf.frame_cues.MARGIN_PX` inside the region's edges
    that are not the image's). ``colour_gradients`` (our extension; the paper: grey levels):
    the edge and ridge derivatives of the R, G, B channel that is strongest at each pixel
    (:func:`strongest_channel`), so clothes as bright as the background still have edges."""
    origin = (0, 0)
    if region is not None:
        u0, v0, u1, v1 = region
        image, origin = image[v0:v1, u0:u1], (u0, v0)
    rgb = image.astype(np.float32) / 255.0
    if colour_gradients:
        grey = rgb                                   # read only: the RGB map too
    else:
        grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32) / 255.0
    g = cv2.GaussianBlur(grey, (5, 5), 1.0)
    sel, mag = _strongest_norm(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3, scale=1.0 / 8.0),
                               cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3, scale=1.0 / 8.0))
    gradient = np.empty(mag.shape + (2,), np.float32)
    _edge_planes(sel, mag, _tanh_scaled(mag, k_edge), gradient)
    pyramid = [g]
    for _ in range(1, levels):
        pyramid.append(cv2.pyrDown(pyramid[-1]))
    shapes = np.array([lv.shape[:2] for lv in pyramid])
    rows = np.concatenate([[0], np.cumsum(shapes[:-1, 0] + 1)])
    ridge = np.zeros((int(np.sum(shapes[:, 0] + 1)), shapes[0, 1], 4), np.float32)
    for lv, (h, w), r in zip(pyramid, shapes, rows, strict=True):
        sel, mag = _strongest_norm(cv2.Sobel(lv, cv2.CV_32F, 2, 0, ksize=3, scale=0.25),
                                   cv2.Sobel(lv, cv2.CV_32F, 1, 1, ksize=3, scale=0.25),
                                   cv2.Sobel(lv, cv2.CV_32F, 0, 2, ksize=3, scale=0.25))
        _ridge_planes(sel, mag, _tanh_scaled(mag, k_ridge), ridge[r:r + h, :w])
    skin = (skin_lut.posterior(image) > 0.5).astype(np.float32)
    return CueMaps(gradient, ridge, shapes, rows, rgb, skin, origin)


def edge_response(maps: CueMaps, uv: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Schmidt eqs. 1-2: ``(N, L)`` mean ``|g_v cos a - g_u sin a|`` over the points
    ``uv (N, L, M, 2)`` of limbs at image angles ``angle (N, L)`` (off-image points count 0):
    the imaginary part of ``(g_u + i g_v) e^{-i a}``."""
    g = sample(maps.gradient, uv, maps.origin).view(np.complex64)[..., 0]
    rot = np.exp(-1j * angle.astype(np.float32))[..., None]
    return _mean_last(np.abs((g * rot).imag))


def ridge_level(width_px: np.ndarray, levels: int) -> np.ndarray:
    """Pyramid level per limb: ``mu = round(log2(width / RIDGE_WIDTH_PX))`` clipped to the
    pyramid (the paper picks it from the limb's distance to the camera)."""
    mu = np.rint(np.log2(np.fmax(width_px, 1e-3) / RIDGE_WIDTH_PX))   # fmax: NaN -> 1e-3
    return np.minimum(np.maximum(mu, 0), levels - 1).astype(np.intp)


def ridge_response(maps: CueMaps, uv: np.ndarray, width_px: np.ndarray, angle: np.ndarray
                   ) -> np.ndarray:
    """Schmidt eqs. 3-4: ``(N, L)`` mean ridge response over the axis points ``uv (N, L, M, 2)``
    at the pyramid level of each limb's mean width ``width_px (N, L)`` (one gather from the
    levels laid end to end; off-image points count 0). With ``s, c = sin a, cos a`` the
    curvature across the limb is ``s^2 uu + c^2 vv - 2 sc uv = T - P`` and along it
    ``c^2 uu + s^2 vv + 2 sc uv = T + P``, where ``T = (uu + vv) / 2`` and
    ``P = cos 2a (uu - vv) / 2 + sin 2a uv = Re(((uu - vv) / 2 + i uv) e^{-2ia})``."""
    shapes = maps.level_shapes
    mu = ridge_level(width_px, len(shapes))[..., None]                          # (N, L, 1)
    m = np.empty(uv.shape)
    scale = 0.5 ** mu
    u0, v0 = maps.origin                                  # multiples of 2^mu (cue_maps)
    np.minimum(np.maximum(np.rint(uv[..., 0] * scale) - u0 * scale, -1.0), shapes[mu, 1],
               out=m[..., 0])              # clipped to [-1, W_mu] (ufuncs: no np.clip wrapper)
    np.minimum(np.maximum(np.rint(uv[..., 1] * scale) - v0 * scale, -1.0), shapes[mu, 0],
               out=m[..., 1])
    m[..., 1] += maps.level_rows[mu]
    got = sample(maps.ridge, m).view(np.complex64)                       # (N, L, M, 2)
    t = got[..., 1].real
    p = (got[..., 0] * np.exp(-2j * angle.astype(np.float32))[..., None]).real
    return _mean_last(np.abs(t - p) - np.abs(t + p))


#: Fractions (along, across) of a band quadrilateral where the colour is sampled (M_C = 9).
_QUAD_GRID = np.array([(a, b) for a in (0.2, 0.5, 0.8) for b in (0.2, 0.5, 0.8)])


#: (4, M_C) bilinear weights of the corners at the :data:`_QUAD_GRID` points.
_QUAD_W = np.stack([(1 - _QUAD_GRID[:, 0]) * (1 - _QUAD_GRID[:, 1]),
                    _QUAD_GRID[:, 0] * (1 - _QUAD_GRID[:, 1]),
                    _QUAD_GRID[:, 0] * _QUAD_GRID[:, 1],
                    (1 - _QUAD_GRID[:, 0]) * _QUAD_GRID[:, 1]])


def band_points(quads: np.ndarray) -> np.ndarray:
    """Sample points ``(..., M_C, 2)`` inside quadrilaterals ``(..., 4, 2)`` (corners in order:
    side 1 base, side 1 top, side 2 top, side 2 base), bilinear in the corners."""
    return np.stack([quads[..., 0] @ _QUAD_W, quads[..., 1] @ _QUAD_W], -1)


def band_colours(maps: CueMaps, quads: np.ndarray) -> np.ndarray:
    """Mean RGB ``(..., 3)`` over each quadrilateral's sample points (off-image points black)."""
    pts = stack([quads[..., 0] @ _QUAD_W, quads[..., 1] @ _QUAD_W], -1)      # (..., M_C, 2)
    got = sample(maps.rgb, pts, maps.origin)                              # (..., M_C, 3)
    flat = got.reshape(-1, got.shape[-2] * 3) @ _CHANNEL_MEAN             # a matrix product:
    return flat.reshape(got.shape[:-2] + (3,))                            # fast on rows of 27


#: (M_C * 3, 3) the mean over the sample points of each channel, of rows ``[r g b r g b ...]``.
_CHANNEL_MEAN = np.tile(np.eye(3, dtype=np.float32), (len(_QUAD_GRID), 1)) / len(_QUAD_GRID)


def colour_response(colours: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Schmidt eqs. 5-6: ``(N, L)`` mean over a limb's bands of ``||C_t - C_ref||``, colours
    ``(N, L, B, 3)`` against references ``(L, B, 3)``."""
    d = colours - reference
    r, g, b = d[..., 0], d[..., 1], d[..., 2]    # components: numpy is slow on a last axis of 3
    return np.add.reduce(np.sqrt(r * r + g * g + b * b), axis=-1) / colours.shape[-2]


#: Unit-circle offsets where the skin cue samples an ellipse (centre and two rings; M_S = 17).
_DISC = np.concatenate([[[0.0, 0.0]]] + [
    r * np.stack([np.cos(t), np.sin(t)], -1)
    for r, t in ((0.45, np.linspace(0, 2 * np.pi, 8, endpoint=False)),
                 (0.85, np.linspace(0, 2 * np.pi, 8, endpoint=False) + np.pi / 8))])


def skin_response(maps: CueMaps, centre: np.ndarray, axes: np.ndarray, angle: np.ndarray
                  ) -> np.ndarray:
    """Schmidt eq. 8: ``(N, E)`` fraction of skin among the sample points of image ellipses
    (centres ``(N, E, 2)``, semi-axes ``(N, E, 2)`` major/minor, major axis angle ``(N, E)``)."""
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    x = _DISC[:, 0] * axes[..., :1]
    y = _DISC[:, 1] * axes[..., 1:]
    pts = stack([centre[..., :1] + c * x - s * y, centre[..., 1:] + s * x + c * y], -1)
    return _mean_last(sample(maps.skin, pts, maps.origin))
