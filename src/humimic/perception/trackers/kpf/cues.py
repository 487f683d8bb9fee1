"""Schmidt, Fritsch & Kwolek's image cues (sec. 4), computed once per frame as maps and sampled
at every particle's feature points in one numpy pass.

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
from functools import cached_property

import cv2
import numpy as np

from humimic.perception.cues.color_models import ColorLUT

#: Width (px) of a bright/dark bar that the 3x3 second derivative of the pyramid responds to best.
RIDGE_WIDTH_PX = 4.0


def _normalise(g: np.ndarray, k: float) -> np.ndarray:
    """``(C, H, W)`` derivative planes scaled by ``tanh(|g| / k) / |g|`` (Sidenbladh's
    non-linear normalisation, one magnitude over all planes)."""
    mag = np.sqrt(np.sum(g * g, axis=0))
    return g * (np.tanh(mag / k) / np.maximum(mag, 1e-6))


@dataclass(frozen=True)
class CueMaps:
    """One frame's cue maps (float32)."""

    grad: np.ndarray
    """(2, H, W) normalised ``d/du``, ``d/dv``."""
    hessian: tuple[np.ndarray, ...]
    """Per pyramid level, (3, H_mu, W_mu) normalised ``uu``, ``uv``, ``vv``."""
    rgb: np.ndarray
    """(H, W, 3) in [0, 1]."""
    skin: np.ndarray
    """(H, W) 1 where skin."""

    @property
    def shape(self) -> tuple[int, int]:
        return self.rgb.shape[:2]

    @cached_property
    def hessian_flat(self) -> np.ndarray:
        """(3, sum of the levels' pixels): the levels' planes raveled end to end."""
        return np.concatenate([hm.reshape(3, -1) for hm in self.hessian], axis=1)

    @cached_property
    def rgb_planes(self) -> np.ndarray:
        """(3, H W) the colour channels raveled (gathers of one channel at a time)."""
        return np.ascontiguousarray(self.rgb.reshape(-1, 3).T)


def cue_maps(image: np.ndarray, skin_lut: ColorLUT, levels: int = 3, k_edge: float = 0.15,
             k_ridge: float = 0.05) -> CueMaps:
    """Cue maps of an RGB uint8 image; ``k_edge`` / ``k_ridge`` the normalisation's contrast
    scales (grey levels in [0, 1] per pixel, per pixel^2)."""
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32) / 255.0
    g = cv2.GaussianBlur(grey, (5, 5), 1.0)
    grad = np.stack([cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8.0,
                     cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8.0])
    hess = []
    level = g
    for mu in range(levels):
        if mu:
            level = cv2.pyrDown(level)
        hess.append(_normalise(np.stack([
            cv2.Sobel(level, cv2.CV_32F, 2, 0, ksize=3) / 4.0,
            cv2.Sobel(level, cv2.CV_32F, 1, 1, ksize=3) / 4.0,
            cv2.Sobel(level, cv2.CV_32F, 0, 2, ksize=3) / 4.0]), k_ridge))
    skin = (skin_lut.posterior(image) > 0.5).astype(np.float32)
    return CueMaps(_normalise(grad, k_edge), tuple(hess), image.astype(np.float32) / 255.0, skin)


def _pixels(u: np.ndarray, v: np.ndarray, shape: tuple[int, int]
            ) -> tuple[np.ndarray, np.ndarray]:
    """Flat pixel indices (nearest) of points ``(u, v)`` and whether they fall inside (NaN
    points do not)."""
    h, w = shape
    with np.errstate(invalid="ignore"):
        ui, vi = np.rint(u).astype(np.intp), np.rint(v).astype(np.intp)
    inside = (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h) & np.isfinite(u) & np.isfinite(v)
    return np.where(inside, vi * w + ui, 0), inside


def _mean_inside(values: np.ndarray, inside: np.ndarray, outside: float) -> np.ndarray:
    """Mean over the last axis of ``values`` where ``inside``; ``outside`` counts for points off
    the image."""
    return np.mean(np.where(inside, values, outside), axis=-1)


def edge_response(maps: CueMaps, uv: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Schmidt eqs. 1-2: ``(N, L)`` mean ``|g_v cos a - g_u sin a|`` over the points
    ``uv (N, L, M, 2)`` of limbs at image angles ``angle (N, L)``."""
    idx, inside = _pixels(uv[..., 0], uv[..., 1], maps.shape)
    gu, gv = maps.grad[0].ravel()[idx], maps.grad[1].ravel()[idx]
    c = np.cos(angle)[..., None].astype(np.float32)
    s = np.sin(angle)[..., None].astype(np.float32)
    return _mean_inside(np.abs(gv * c - gu * s), inside, 0.0)


def ridge_level(width_px: np.ndarray, levels: int) -> np.ndarray:
    """Pyramid level per limb: ``mu = round(log2(width / RIDGE_WIDTH_PX))`` clipped to the
    pyramid (the paper picks it from the limb's distance to the camera)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = np.rint(np.log2(np.maximum(width_px, 1e-3) / RIDGE_WIDTH_PX))
    return np.clip(np.nan_to_num(mu), 0, levels - 1).astype(np.intp)


def ridge_response(maps: CueMaps, uv: np.ndarray, width_px: np.ndarray, angle: np.ndarray
                   ) -> np.ndarray:
    """Schmidt eqs. 3-4: ``(N, L)`` mean ridge response over the axis points ``uv (N, L, M, 2)``
    at the pyramid level of each limb's mean width ``width_px (N, L)`` (one gather from the
    levels laid end to end)."""
    mu = ridge_level(width_px, len(maps.hessian))[..., None]                   # (N, L, 1)
    shapes = np.array([hm.shape[1:] for hm in maps.hessian])                   # (levels, 2)
    offsets = np.concatenate([[0], np.cumsum(shapes[:, 0] * shapes[:, 1])[:-1]])
    scale = 0.5 ** mu
    u = np.rint(uv[..., 0] * scale).astype(np.intp)
    v = np.rint(uv[..., 1] * scale).astype(np.intp)
    h, w = shapes[mu, 0], shapes[mu, 1]
    inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
    idx = np.where(inside, offsets[mu] + v * w + u, 0)
    flat = maps.hessian_flat
    uu, uv_, vv = flat[0][idx], flat[1][idx], flat[2][idx]
    c = np.cos(angle)[..., None].astype(np.float32)
    s = np.sin(angle)[..., None].astype(np.float32)
    across = np.abs(s * s * uu + c * c * vv - 2 * s * c * uv_)
    along = np.abs(c * c * uu + s * s * vv + 2 * s * c * uv_)
    return _mean_inside(across - along, inside, 0.0)


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
    """Mean RGB ``(..., 3)`` over each quadrilateral's sample points (off-image points black;
    coordinate and channel planes: numpy is slow on trailing axes of size 2 and 3)."""
    idx, inside = _pixels(quads[..., 0] @ _QUAD_W, quads[..., 1] @ _QUAD_W, maps.shape)
    return np.stack([np.mean(plane[idx] * inside, axis=-1) for plane in maps.rgb_planes], -1)


def colour_response(colours: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Schmidt eqs. 5-6: ``(N, L)`` mean over a limb's bands of ``||C_t - C_ref||``, colours
    ``(N, L, B, 3)`` against references ``(L, B, 3)``."""
    return np.mean(np.linalg.norm(colours - reference, axis=-1), axis=-1)


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
    idx, inside = _pixels(centre[..., :1] + c * x - s * y, centre[..., 1:] + s * x + c * y,
                          maps.shape)
    return _mean_inside(maps.skin.ravel()[idx], inside, 0.0)
