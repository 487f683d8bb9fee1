"""The hand tracker's measurement model (Menezes sec. 5.1), vectorised over particles.

One frame's cue images are computed once, in a region of interest around the particles
(:class:`FrameCues`: Canny edges, their distance transform, the moving edges from optical flow
and theirs; the image quantised for colour histograms). The per-particle log-likelihood fuses
the chosen cues (eq. 7):

* ``shape``: eq. 2 (nearest edge along each template normal) or eq. 3 (distance transform);
* ``shape`` + ``motion``: eq. 4 (moving edges free, static ones cost ``rho``) or eq. 5
  (``min(I_DT, K I'_DT)``);
* ``colour``: eq. 6 on one patch over the palm against a reference histogram (eq. 13 updates
  it in the tracker);
* ``skin`` (added here): the skin posterior just inside against just outside the template
  (:mod:`humimic.perception.cues.skin`), which keeps the estimate on the hand where clutter
  gives the shape cue edges everywhere.

The shape distance is a *sum* over the ``N_p`` points, as Table 3's sigma_s = 36 for 30 points
reads (see :mod:`humimic.perception.cues.edges`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from humimic.maths.jit import njit
from humimic.perception.cues.edges import (
    colour_canny,
    distance_transform,
    dt_distance,
    normal_edge_distance,
    shape_log_likelihood,
)
from humimic.perception.cues.fusion import fuse
from humimic.perception.cues.histograms import (
    QuantizedImage,
    color_log_likelihood,
    patch_grid,
    patch_histograms,
)
from humimic.perception.cues.motion import (
    MotionEdgeMaps,
    motion_dt_distance,
    motion_normal_distance,
    moving_edges,
)
from humimic.perception.cues.skin import rim_skin_distance
from humimic.perception.cues.templates import Template

PALM_PATCH = np.array([[0.0, 0.0, 0.6, 1.2]])
"""The colour patch: the palm, in hand widths about the hand's centre (the hand is 1.78 hand
widths tall)."""


@dataclass(frozen=True)
class Params:
    """What the likelihood needs of :class:`~.config.Hand2DConfig`."""

    cues: tuple[str, ...]
    similarity: str
    sigma_s: float
    rho: float
    K: float
    search_px: int
    sigma_c: float
    sigma_k: float = 0.15


@dataclass(frozen=True)
class FrameCues:
    """One frame's cue images; edge maps cover the ROI whose top-left pixel is ``origin``."""

    maps: MotionEdgeMaps
    origin: np.ndarray
    """(2,) (x0, y0) of the ROI in the image."""
    qimage: QuantizedImage | None
    skin: np.ndarray | None = None
    """Skin posterior over the ROI (float32), for the ``skin`` cue."""


def roi_of(points: np.ndarray, margin: float, width: int, height: int
           ) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` bounding the points ``(..., 2)`` plus ``margin``, in the image."""
    p = np.asarray(points, np.float64).reshape(-1, 2)
    b = _bounds(p)                           # the points' nanmin / nanmax of u and v
    if np.isfinite(b).all():                 # scalars: numpy's floor of 2-vectors costs more
        lo = (math.floor(b[0] - margin), math.floor(b[1] - margin))
        hi = (math.ceil(b[2] + margin) + 1, math.ceil(b[3] + margin) + 1)
    else:                                    # NaN (no finite point) or inf: numpy's casts
        lo = np.floor(b[:2] - margin).astype(int)
        hi = np.ceil(b[2:] + margin).astype(int) + 1
    x0, y0 = max(0, min(lo[0], width - 2)), max(0, min(lo[1], height - 2))
    x1, y1 = min(width, max(hi[0], x0 + 2)), min(height, max(hi[1], y0 + 2))
    return x0, y0, x1, y1


@njit
def _bounds(p: np.ndarray) -> np.ndarray:
    """``(nanmin u, nanmin v, nanmax u, nanmax v)`` of points ``(n, 2)`` in one compiled pass
    (NaN where no point has a number: ``np.nanmin``'s result)."""
    out = np.array([np.inf, np.inf, -np.inf, -np.inf])
    seen = np.zeros(2, np.bool_)
    for i in range(len(p)):
        for c in range(2):
            x = p[i, c]
            if x == x:
                seen[c] = True
                out[c] = min(out[c], x)
                out[2 + c] = max(out[2 + c], x)
    for c in range(2):
        if not seen[c]:
            out[c] = out[2 + c] = np.nan
    return out


def frame_cues(roi_image: np.ndarray, flow: np.ndarray | None, origin, p: Params,
               min_flow_px: float, qimage: QuantizedImage | None, need_dt: bool = False,
               skin: np.ndarray | None = None) -> FrameCues:
    """Edges and moving edges of an ROI (``flow`` over the same ROI, or None: nothing
    moves), with their distance transforms only where the similarity (or ``need_dt``) asks.
    A grey ROI gets Canny on its grey levels (the paper), an RGB one Canny on its colour
    gradient (:func:`~humimic.perception.cues.edges.colour_canny`, ``edges: colour``)."""
    edges = colour_canny(roi_image)
    moving = (moving_edges(edges, flow, min_flow_px) if flow is not None
              else np.zeros_like(edges))
    dt = distance_transform(edges) if need_dt or p.similarity == "dt" else None
    dt_moving = (distance_transform(moving) if p.similarity == "dt" and "motion" in p.cues
                 else None)
    return FrameCues(MotionEdgeMaps(edges, moving, dt, dt_moving), np.asarray(origin, float),
                     qimage, skin)


def shape_distance(cues: FrameCues, states: np.ndarray, template: Template, p: Params,
                   placed: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Sum over the template points of their edge distance (eqs. 2-5), ``(N,)``; ``placed``:
    ``template.place(states)`` if already computed."""
    pts, nrm = placed if placed is not None else template.place(states)
    pts = pts - cues.origin
    m = cues.maps
    if "motion" in p.cues:
        if p.similarity == "normal":
            return motion_normal_distance(m, pts, nrm, p.rho, p.search_px, "sum")  # eq. 4
        return motion_dt_distance(m, pts, p.K, reduce="sum")  # Menezes eq. 5
    if p.similarity == "normal":
        return normal_edge_distance(m.edges, pts, nrm, p.search_px, "sum")  # Menezes eq. 2
    return dt_distance(m.dt, pts, reduce="sum")  # Menezes eq. 3


def log_likelihood(cues: FrameCues, states: np.ndarray, template: Template, p: Params,
                   reference: np.ndarray | None) -> np.ndarray:
    """Menezes eq. 7: the fused log-likelihood of the chosen cues for states ``(N, 4)``."""
    terms = []
    placed = template.place(states)
    if "shape" in p.cues:
        terms.append(shape_log_likelihood(shape_distance(cues, states, template, p, placed),
                                          p.sigma_s))
    if "skin" in p.cues and cues.skin is not None:   # the template's normals point inwards
        pts, inward = placed
        terms.append(shape_log_likelihood(
            rim_skin_distance(cues.skin, pts - cues.origin, -inward), p.sigma_k))
    if "colour" in p.cues and reference is not None:
        hists = patch_histograms(cues.qimage, states, PALM_PATCH, grid=6)
        terms.append(color_log_likelihood(hists, reference, p.sigma_c))  # Menezes eq. 6
    if not terms:  # colour alone before a reference exists: flat
        return np.zeros(len(states))
    return fuse(*terms)  # Menezes eq. 7


def mean_edge_distance(cues: FrameCues, state: np.ndarray, template: Template, p: Params
                       ) -> float:
    """Mean edge distance (px) of the template points of one state: along the normals
    (capped at ``search_px``) or by distance transform, as the similarity."""
    pts, nrm = template.place(np.asarray(state)[None])
    if cues.maps.dt is not None:
        return float(dt_distance(cues.maps.dt, pts - cues.origin)[0])
    return float(normal_edge_distance(cues.maps.edges, pts - cues.origin, nrm, p.search_px)[0])


def skin_fraction(image: np.ndarray, lut, state: np.ndarray, grid: int = 6) -> float:
    """Mean skin probability (``lut.posterior``) over a ``grid x grid`` lattice of pixels on
    the palm of one state; lattice points off the image count 0."""
    pts = patch_grid(np.asarray(state)[None], PALM_PATCH, grid).reshape(-1, 2)
    h, w = image.shape[:2]
    col, row = np.floor(pts[:, 0] + 0.5).astype(int), np.floor(pts[:, 1] + 0.5).astype(int)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    if not inside.any():
        return 0.0
    return float(lut.posterior(image[row[inside], col[inside]]).sum() / len(pts))
