"""The skin inside/outside cue of a contour (added here to Menezes' shape and colour cues).

Where a hand's grey-level edges are weak (a dark hand over a dark shirt) or drowned in clutter
(a speckled cupboard behind a waving hand), the skin posterior still says which side of a
contour the hand is on: ``D = 1 - (mean skin just inside - mean skin just outside)`` in
[0, 2], 0 for a contour on the rim of a skin region, 1 where skin is on neither or both sides,
2 for the contour of a hole in skin. Used by GEST (on the projected ellipse) and the 2-D hand
tracker (on its template) with :func:`~humimic.perception.cues.edges.shape_log_likelihood`.
"""

from __future__ import annotations

import numpy as np

from humimic.maths.jit import njit
from humimic.perception.cues.edges import sample_uv


def rim_skin_distance(skin: np.ndarray, contour: np.ndarray, outward: np.ndarray,
                      offset_px: float = 2.0) -> np.ndarray:
    """``D = 1 - (inside - outside)`` per contour ``(..., n, 2)`` (px) with outward unit
    normals ``outward`` (same shape): the skin posterior map ``skin`` sampled bilinearly
    ``offset_px`` either side of every point (off the map counts 0), averaged over the
    ``n`` points; one gather for both sides (its probes built in one compiled pass:
    :func:`rim_probes`)."""
    inside, outside = rim_skin_sides(skin, contour, outward, offset_px)
    return 1.0 - (inside - outside)


def rim_skin_sides(skin: np.ndarray, contour: np.ndarray, outward: np.ndarray,
                   offset_px: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """``(inside, outside)``: the mean skin posterior ``offset_px`` inside and outside each
    contour ``(..., n, 2)`` (see :func:`rim_skin_distance`), each of shape ``(...)``."""
    c, o = np.asarray(contour, np.float64), np.asarray(outward, np.float64)
    if c.shape != o.shape:
        full = np.broadcast_shapes(c.shape, o.shape)
        c, o = np.broadcast_to(c, full), np.broadcast_to(o, full)
    u, v = rim_probes(np.ascontiguousarray(c.reshape(-1, 2)),
                      np.ascontiguousarray(o.reshape(-1, 2)), float(offset_px))
    shape = (2,) + c.shape[:-1]
    both = sample_uv(skin, u.reshape(shape), v.reshape(shape), 0.0)
    inside, outside = np.add.reduce(both, axis=-1) / both.shape[-1]   # ndarray.mean's sum
    return inside, outside


def rim_separates(inside, outside, odds: float = 2.0):
    """Whether a rim separates skin from background: its inside at least ``odds`` times as
    skin-like as its outside (``inside >= odds * outside`` and ``inside > 0``; ours): the rim
    half of the 2-D hand tracker's loss test and of GEST's
    (:func:`humimic.perception.trackers.gest.loss.rim_fits`).

    Relative, not absolute: how high the skin posterior of a hand is depends on how well the
    skin model covers that skin and its shading. The 2-D hand tracker's absolute test
    ``D = 1 - (inside - outside) <= 0.5`` asked ``inside - outside >= 0.5``: met on the
    default skin's rim (inside 0.99, outside 0.01 at the median, menezes_fig5_hand s2) but
    not on a very dark hand's shaded rim (skin [0.25, 0.16, 0.11]: inside 0.48-0.79, outside
    0.05-0.43 on the frames it was declared lost while on the hand). For ``inside`` near 1
    the two tests agree (``odds`` 2: outside at most 0.5); a rim with skin on neither side or
    on both (a hand gone, a skin-like surface) fails both."""
    inside, outside = np.asarray(inside, float), np.asarray(outside, float)
    return (inside > 0.0) & (inside >= odds * outside)


@njit
def rim_probes(contour: np.ndarray, outward: np.ndarray, offset_px: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """The probes ``contour -+ offset_px outward`` (points ``(m, 2)``): their ``u`` and ``v``,
    each ``(2 m,)`` float32, the inner side first, each rounded as numpy's
    ``(contour - offset_px * outward).astype(np.float32)`` rounds it."""
    m = len(contour)
    u = np.empty(2 * m, np.float32)
    v = np.empty(2 * m, np.float32)
    for i in range(m):
        su, sv = offset_px * outward[i, 0], offset_px * outward[i, 1]
        u[i], v[i] = contour[i, 0] - su, contour[i, 1] - sv
        u[m + i], v[m + i] = contour[i, 0] + su, contour[i, 1] + sv
    return u, v
