"""GEST's measurement function (Menezes sec. 6.1.2): ``p(z^S, z^C | x) = p(z^S|x) p(z^C|x)``
for hand-ellipsoid states, vectorised over particles.

The ellipsoids are projected with eq. 15 in one compiled pass (:func:`project_views`, on
:func:`.kernels.project_states`: every projection here goes through it; the dual form
:func:`views_components` is its reference in tests); ``n_points`` contour points (at equal
steps of the ellipse's parameter, normals in closed form; checked against the dual-quadric
projection in tests) sample the frame's distance transform (shape cue, eq. 3: ``-D^2 /
(2 sigma_s^2)``); the colour cue compares the histogram of the square
inscribed in the projected ellipse (side ``sqrt(2)`` times its semi-minor axis) with the
reference (eq. 6, one patch). A third cue, not in the paper, gives the colour cue the
"inside/outside information" the paper credits its patches with: the skin posterior
(:class:`~humimic.perception.cues.color_models.ColorLUT`) sampled ``offset_px`` inside and
outside every contour point along its normal, ``D_k = 1 - (mean inside - mean outside)``,
``-D_k^2 / (2 sigma_k^2)``; without it a hand whose outline has weak
grey-level edges (skin on a blue shirt) fits a smaller, farther ellipse as well as the true
one. A fourth, also an addition, is the stereo measurement itself as a cue
(:func:`blob_pair_log_likelihood`): the matched skin blobs' centroids in both images against
the centres of the particle's projected ellipses, a Gaussian mixture over the matched pairs
(``sigma_px``) with a uniform outlier. In the paper the stereo blobs only place particles;
here, with ICONDENSATION's weights computed exactly (the whole mixture proposal against the
predictive density), particles proposed where the random walk cannot reach get little weight,
and the image cues barely see depth (5 cm at 1 m changes them by < 0.3 nats, tests), so the
stereo data must also enter the likelihood. It compares image centres, not triangulated
points: an off-axis ellipsoid's silhouette is not centred on its centre's image (0.3-0.5 px
here, 3 cm of depth at 1 m). Its ``sigma_px`` is what sets the depth accuracy: at the true
pose the full-resolution centroids sit 0.06-0.07 px from the ellipse centres in the rendered
scenes (the tracker uses 0.08 px), a noisier segmentation needs a larger value. Parts behind
the camera or off the image cost the distance transform's cap at every point.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from humimic.bodymodel import conics
from humimic.bodymodel.hand import check_hand_states, hand_ellipsoids
from humimic.bodymodel.projection import Z_MIN
from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.edges import DT_CAP_PX, dt_distance, shape_log_likelihood
from humimic.perception.cues.histograms import patch_color_log_likelihood, patch_histograms
from humimic.perception.cues.skin import rim_skin_distance
from humimic.perception.trackers.frame_cues import FrameCues, frame_cues
from humimic.perception.trackers.gest.kernels import (
    blob_pair_kernel,
    camera_arrays,
    project_states,
    rim_maps,
)
from humimic.perception.trackers.gest.proposal import EXP_FLOOR, logsumexp
from humimic.sensors.camera_model import CameraImage

#: One square patch centred on the ellipse, ``s`` = its side (px) (histograms' patch units).
INSCRIBED = np.array([[0.0, 0.0, 1.0, 1.0]])
OFF_IMAGE = -1.0e6
#: How far inside and outside the contour the skin cue samples (px).
RIM_OFFSET_PX = 2.0


HandView = FrameCues


def hand_view(frame: CameraImage, bins: int, lut: ColorLUT | None = None,
              colour_edges: bool = False) -> HandView:
    return frame_cues(frame, bins, lut, colour_edges=colour_edges)


@dataclass(frozen=True)
class HandProjection:
    contour: np.ndarray
    """(N, n, 2) contour points (px); off-image sentinel where the part is invalid."""
    normal: np.ndarray
    """(N, n, 2) outward unit normals."""
    patch_state: np.ndarray
    """(N, 3) ``(u, v, s)`` of the colour patch (px)."""
    valid: np.ndarray
    """(N,) bool."""


@dataclass(frozen=True)
class CameraGeometry:
    """A camera as :func:`project_views` reads it."""

    intrinsics: object
    T_cam_base: np.ndarray


def hand_outlines(states: np.ndarray, intrinsics, T_cam_base: np.ndarray, n: int = 16
                  ) -> np.ndarray:
    """Eq. 15 for hand states ``(N, 9)`` (:func:`project_views`): their outlines ``(N, n, 2)``
    (px; ``n`` points at equal steps of the image ellipse's parameter) in the camera
    ``intrinsics``, ``T_cam_base``; NaN where the ellipsoid is not wholly in front of it."""
    proj = project_views(states, [CameraGeometry(intrinsics, T_cam_base)], n)[0][0]
    return np.where(proj.valid[:, None, None], proj.contour, np.nan)      # Menezes eq. 15


#: ``(cx, cy, m00, m01, m11)`` of an invalid part: a unit circle at the origin (masked later).
_INVALID = np.array([0.0, 0.0, 1.0, 0.0, 1.0])


def views_components(ellipsoids: tuple, T_cam_base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tests' reference for :func:`project_views` (production projects through that
    compiled path only): eq. 15 (in its dual form, :func:`~humimic.bodymodel.conics.
    dual_ellipse`) for
    ellipsoids ``(R, centre, semi-axes)`` (base frame, as
    :func:`~humimic.bodymodel.hand.hand_ellipsoids` gives them, ``N`` of them) in ``V``
    cameras at once (``T_cam_base (V, 4, 4)``): the image ellipses ``(5, V, N)`` as ``cx, cy,
    m00, m01, m11`` (centre and shape matrix, normalised coordinates; a unit circle where
    invalid) and whether each ellipsoid lies wholly in front of each camera ``(V, N)``.
    ``R S^2 R^T`` is formed once in the base frame and turned into every camera by one matrix
    product with ``kron(R_cam, R_cam)`` (no batched 3x3 products: numpy's cost ~1 us each)."""
    R, c, axes = ellipsoids
    T = np.asarray(T_cam_base, float)
    v = len(T)
    Rc = T[:, :3, :3]
    B = np.einsum("nik,njk->nij", R * np.square(axes)[:, None, :], R).reshape(-1, 9)
    K = np.einsum("vik,vjl->vijkl", Rc, Rc).reshape(v, 9, 9)[:, conics.UPPER]   # (V, 6, 9)
    Bc = (B @ K.reshape(v * 6, 9).T).reshape(-1, v, 6).transpose(1, 0, 2)     # (V, N, 6)
    t = (c @ Rc.reshape(v * 3, 3).T).reshape(-1, v, 3).transpose(1, 0, 2) + T[:, None, :3, 3]
    e = np.stack(conics.dual_ellipse(Bc, t)[:5])                          # Menezes eq. 15
    # wholly in front: the ellipsoid's reach along the optical axis is sqrt(B_22)
    valid = t[..., 2] - np.sqrt(np.maximum(Bc[..., 5], 0.0)) > Z_MIN
    valid &= np.isfinite(e).all(axis=0)
    return np.where(valid, e, _INVALID[:, None, None]), valid


def pixel_centres(centre: np.ndarray, valid: np.ndarray, intrinsics) -> np.ndarray:
    """Pixel centres ``(N, 2)`` of image ellipses (normalised ``centre (N, 2)``), off-image
    sentinel where not ``valid``."""
    cu, cv = intrinsics.distort(centre[:, 0], centre[:, 1])
    return np.where(valid[:, None], np.stack([cu, cv], -1), OFF_IMAGE)


def ellipse_centres(states: np.ndarray, views: list) -> np.ndarray:
    """Pixel centres ``(N, V, 2)`` of hand states' ``(N, 9)`` image ellipses in ``views``
    (off-image sentinel where invalid): :func:`project_views` without contours."""
    return project_views(states, views, 0, 0)[1]


@functools.lru_cache(maxsize=16)
def _circle(n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """``cos psi, sin psi`` at ``n_points`` equal steps (read-only)."""
    psi = np.linspace(0.0, 2.0 * np.pi, n_points, endpoint=False)
    cos, sin = np.cos(psi), np.sin(psi)
    cos.setflags(write=False)
    sin.setflags(write=False)
    return cos, sin


def components_projection(e: np.ndarray, valid: np.ndarray, intrinsics, n_points: int
                          ) -> HandProjection:
    """Contour points, normals and colour patch (:func:`project_hands`'s, in array operations:
    the tests' reference) of image ellipses
    given as ``e (5, N)`` = ``cx, cy, m00, m01, m11`` (:func:`views_components`) and ``valid
    (N,)``: ``centre + L (cos psi, sin psi)`` with ``L`` the Cholesky factor of ``M``, normals
    ``L^-T (cos psi, sin psi)``."""
    cx, cy, m00, m01, m11 = e
    n = len(cx)
    l00 = np.sqrt(np.maximum(m00, 1e-300))
    l10 = m01 / l00
    l11 = np.sqrt(np.maximum(m11 - l10 * l10, 1e-300))
    cos, sin = _circle(n_points)
    K = intrinsics
    uv = np.empty((n, n_points, 2))
    uv[..., 0], uv[..., 1] = K.distort(cx[:, None] + l00[:, None] * cos,
                                       cy[:, None] + l10[:, None] * cos + l11[:, None] * sin)
    normal = np.empty((n, n_points, 2))
    nx, ny = normal[..., 0], normal[..., 1]
    np.multiply(cos, (1.0 / l00)[:, None], out=nx)
    nx -= (l10 / (l00 * l11))[:, None] * sin
    np.multiply(sin, (1.0 / l11)[:, None], out=ny)
    normal /= np.hypot(nx, ny)[..., None]
    # semi-minor axis: the smaller eigenvalue of M (conics.ellipse_axes in components)
    minor = np.sqrt(np.maximum(0.5 * (m00 + m11) - np.hypot(0.5 * (m00 - m11), m01), 0.0))
    patch = np.empty((n, 3))
    patch[:, 0], patch[:, 1] = K.distort(cx, cy)
    patch[:, 2] = np.sqrt(2.0) * K.fx * minor
    if not valid.all():
        uv[~valid] = OFF_IMAGE
        patch[~valid] = (OFF_IMAGE, OFF_IMAGE, 1.0)
    return HandProjection(uv, normal, patch, valid)


def project_hands(states: np.ndarray, view: HandView, n_points: int) -> HandProjection:
    """Eq. 15 for every particle's ellipsoid, and its contour points and colour patch, in one
    view (:func:`project_views`).

    The ``n_points`` contour points are ``centre + L (cos psi, sin psi)`` at equal steps of
    ``psi`` (``L L^T`` the image ellipse's shape matrix), with their normals in closed form
    (``L^-T (cos psi, sin psi)``); not resampled by arc length as the body model's outlines
    are (that resampling was most of the likelihood's cost)."""
    return project_views(states, [view], n_points)[0][0]


def project_views(states: np.ndarray, views: list, n_points: int,
                  image_views: int | None = None) -> tuple[list[HandProjection | None],
                                                           np.ndarray]:
    """:func:`project_hands` in the first ``image_views`` of ``views`` (all if None; None for
    the others), and the pixel centres ``(N, V, 2)`` of the image ellipses in every view: eq.
    15 in one compiled pass over the particles and views (:func:`.kernels.project_states`;
    :func:`project_views_numpy` is the array form)."""
    states = np.ascontiguousarray(np.atleast_2d(states), float)
    check_hand_states(states)
    ni = len(views) if image_views is None else min(image_views, len(views))
    T, K = camera_arrays(views)
    cos, sin = _circle(n_points)
    contour, normal, patch, valid, centres = project_states(states, T, K, cos, sin, ni)  # eq. 15
    projs = [HandProjection(contour[i], normal[i], patch[i], valid[i]) if i < ni else None
             for i in range(len(views))]
    return projs, centres


def project_views_numpy(states: np.ndarray, views: list, n_points: int,
                  image_views: int | None = None, ellipsoids: tuple | None = None
                  ) -> tuple[list[HandProjection | None], np.ndarray]:
    """:func:`project_views` in array operations (its reference in tests; ``ellipsoids``:
    :func:`hand_ellipsoids` of ``states`` if already computed)."""
    if ellipsoids is None:
        ellipsoids = hand_ellipsoids(states)
    e, valid = views_components(ellipsoids, np.stack([v.T_cam_base for v in views]))
    projs = []
    centres = np.empty((e.shape[2], len(views), 2))
    for i, view in enumerate(views):
        if image_views is not None and i >= image_views:
            projs.append(None)
            centres[:, i] = pixel_centres(e[:2, i].T, valid[i], view.intrinsics)
            continue
        proj = components_projection(e[:, i], valid[i], view.intrinsics, n_points)
        projs.append(proj)
        centres[:, i] = proj.patch_state[:, :2]
    return projs, centres


REMAP_ROWS = 16384
"""Rows per ``cv2.remap`` call (OpenCV takes fewer than 32767: 2 rows a particle)."""


def _sampled_mean(image: np.ndarray, maps: np.ndarray, outside: float) -> np.ndarray:
    """The mean over the last point axis of ``image`` sampled bilinearly (points off it read
    ``outside``) at the float32 points ``maps (..., n, 2)``: one ``cv2.remap`` with a
    two-channel map, the same samples as :func:`~humimic.perception.cues.edges.sample`'s two
    one-channel maps."""
    src = image if image.dtype in (np.uint8, np.float32) else image.astype(np.float32)
    n = maps.shape[-2]
    if maps.size == 0:
        return np.zeros(maps.shape[:-2])
    rows = maps.reshape(-1, n, 2)
    out = np.concatenate([cv2.remap(src, rows[i:i + REMAP_ROWS], None, cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT, borderValue=float(outside))
                          for i in range(0, len(rows), REMAP_ROWS)])
    return out.reshape(maps.shape[:-1]).astype(np.float64).mean(axis=-1)


def rim_distances(proj: HandProjection, view: HandView, offset_px: float = RIM_OFFSET_PX
                  ) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`shape_distance` and :func:`skin_distance` (None without a skin map) from the
    float32 sample points of :func:`.kernels.rim_maps`: one conversion, one gather per cue
    image (equal to the two functions, which are their references in tests)."""
    maps = rim_maps(proj.contour, proj.normal, float(offset_px))
    d = _sampled_mean(view.dt, maps[0], DT_CAP_PX)                      # Menezes eq. 3
    if view.skin is None:
        return d, None
    inside, outside = _sampled_mean(view.skin, maps[1:], 0.0)
    return d, 1.0 - (inside - outside)


def shape_distance(proj: HandProjection, view: HandView) -> np.ndarray:
    """Menezes eq. 3: mean distance-transform value at the contour points (px)."""
    return dt_distance(view.dt, proj.contour, DT_CAP_PX)              # Menezes eq. 3


def skin_distance(proj: HandProjection, view: HandView, offset_px: float = RIM_OFFSET_PX
                  ) -> np.ndarray:
    """``D_k = 1 - (mean skin inside - mean skin outside)`` in [0, 2] (module docstring),
    sampled ``offset_px`` either side of the contour along its normals."""
    return rim_skin_distance(view.skin, proj.contour, proj.normal, offset_px)


def ellipse_family(centre: np.ndarray, semi_axes: np.ndarray, angles: np.ndarray,
                   n_points: int) -> HandProjection:
    """Image ellipses about one ``centre (2,)`` (px), every one of ``semi_axes (P, 2)`` (px)
    turned by every one of ``angles (A,)`` (rad, from +u towards +v): contour points
    ``c + R(theta) (a cos psi, b sin psi)`` and outward unit normals ``R(theta) (cos psi / a,
    sin psi / b)`` (normalised), ``(P * A, n_points, 2)``, rows ordered pair-major."""
    cos, sin = _circle(n_points)
    ab = np.repeat(np.asarray(semi_axes, float), len(angles), axis=0)          # (P*A, 2)
    th = np.tile(np.asarray(angles, float), len(semi_axes))
    contour = conics.rotated_ellipse_points(np.asarray(centre, float), ab, np.cos(th),
                                            np.sin(th), np.stack([cos, sin], -1))
    ct, st = np.cos(th)[:, None], np.sin(th)[:, None]
    nx, ny = cos / ab[:, :1], sin / ab[:, 1:]
    normal = np.stack([ct * nx - st * ny, st * nx + ct * ny], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    k = len(ab)
    return HandProjection(contour, normal, np.tile(np.r_[centre, 1.0], (k, 1)),
                          np.ones(k, bool))


def blob_pair_log_likelihood(centres: np.ndarray, pairs: np.ndarray, sigma_px: float,
                             outlier_density: float) -> np.ndarray:
    """``log(outlier + sum_j prod_v N(c_v; m_jv, sigma^2 I) / M)`` for the particles' ellipse
    centres ``(N, V, 2)`` and the matched blob centroids ``pairs (M, V, 2)`` (px), compiled
    (:func:`.kernels.blob_pair_kernel`; :func:`blob_pair_log_likelihood_numpy` is the array
    form)."""
    centres, pairs = np.asarray(centres, float), np.asarray(pairs, float)
    if pairs.size and pairs.shape[1:] != centres.shape[1:]:
        raise ValueError(f"pairs {pairs.shape} must be (M, *{centres.shape[1:]}) for "
                         f"centres {centres.shape}")
    return blob_pair_kernel(np.ascontiguousarray(centres), np.ascontiguousarray(
        pairs).reshape(-1, *centres.shape[1:]), float(sigma_px),
        math.log(outlier_density), EXP_FLOOR)


def blob_pair_log_likelihood_numpy(centres: np.ndarray, pairs: np.ndarray, sigma_px: float,
                                   outlier_density: float) -> np.ndarray:
    """:func:`blob_pair_log_likelihood` in array operations (its reference in tests)."""
    out = np.full(len(centres), np.log(outlier_density))
    if len(pairs):
        d2 = np.sum((centres[:, None] - pairs[None]) ** 2, axis=(2, 3))      # (N, M)
        v = centres.shape[1]
        log_n = -0.5 * d2 / sigma_px ** 2 - v * np.log(2 * np.pi * sigma_px ** 2)
        out = np.logaddexp(out, logsumexp(log_n, axis=1) - np.log(len(pairs)))
    return np.where(np.isfinite(out), out, np.log(outlier_density))


def hand_log_likelihood(states: np.ndarray, views: list[HandView], ref: np.ndarray | None,
                        n_points: int, sigma_s: float, sigma_c: float,
                        sigma_k: float = 0.15, image_views: int | None = None,
                        pairs: np.ndarray | None = None, sigma_px: float = 1.0,
                        outlier: float = 1e-6) -> np.ndarray:
    """``log p(z^S|x) + log p(z^C|x)`` (+ the skin cue where the views have a skin map) over
    the first ``image_views`` of ``views`` (all if None), plus the blob-pair cue when
    ``pairs (M, len(views), 2)`` is given (eq. 7); ``ref (3, bins)`` the reference histogram
    (None: no colour cue)."""
    out = np.zeros(len(states))
    projs, centres = project_views(states, views, n_points, image_views)
    for proj, view in zip(projs, views, strict=True):
        if proj is None:
            continue
        d, d_skin = rim_distances(proj, view)
        out += shape_log_likelihood(d, sigma_s)                           # Menezes eq. 2
        if d_skin is not None:
            out += shape_log_likelihood(d_skin, sigma_k)
        if ref is not None:
            out += patch_color_log_likelihood(view.qimage, proj.patch_state, INSCRIBED,
                                              ref[None], sigma_c)       # Menezes eq. 6
    if pairs is not None:
        out += blob_pair_log_likelihood(centres, pairs, sigma_px, outlier)
    return out


def reference_histogram(proj: HandProjection, view: HandView) -> np.ndarray:
    """``(3, bins)`` histogram of the first projected state's colour patch (eq. 13's
    observation)."""
    return patch_histograms(view.qimage, proj.patch_state[:1], INSCRIBED, grid=8)[0, 0]


def patch_histogram(state: np.ndarray, view: HandView) -> np.ndarray:
    """``(3, bins)`` histogram of one state's colour patch (for the reference, eq. 13)."""
    proj = project_hands(state[None], view, 8)
    return patch_histograms(view.qimage, proj.patch_state, INSCRIBED, grid=8)[0, 0]
