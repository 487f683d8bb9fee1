"""Hidden-part removal: is a point on one part's contour behind another part?

A contour point of part ``i`` (undistorted normalised image point ``x``, inverse depth ``s``)
is hidden when the ray through ``x`` meets another part ``j`` nearer than ``1 / s``: for an
ellipsoid the larger root of Menezes eq. 14 (:func:`conics.ray_quadric_inverse_depth`), for a
cone the exact ray / truncated-cone intersection (:func:`cones.ray_cone_depth`). Only pairs
whose image bounding boxes overlap, and points inside the occluder's box, are tested (gathered
into flat candidate lists), so the cost follows how much the parts overlap in the image.
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel import cones, conics
from humimic.bodymodel.projection import BodyView

#: Relative depth margin: a point on an occluder's own surface (touching parts) is not hidden.
DEPTH_MARGIN = 1e-6


def _boxes(xy: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(N, P, 4) ``xmin, ymin, xmax, ymax`` of outlines in normalised coordinates (NaN-safe:
    invalid parts get an empty box)."""
    filled = np.where(valid[..., None, None], xy, 0.0)
    lo = np.where(valid[..., None], filled.min(axis=-2), np.inf)
    hi = np.where(valid[..., None], filled.max(axis=-2), -np.inf)
    return np.concatenate([lo, hi], axis=-1)


def hidden(view: BodyView, xy: np.ndarray, inv_depth: np.ndarray,
           boxes_xy: np.ndarray | None = None) -> np.ndarray:
    """``(N, P, k)`` bool: points ``xy (N, P, k, 2)`` with ``inv_depth (N, P, k)`` on the
    parts' contours are hidden by another part of the same particle."""
    out = np.zeros(inv_depth.shape, bool)
    valid = view.outline.valid
    box = _boxes(view.outline.xy, valid) if boxes_xy is None else boxes_xy
    n, P, k = inv_depth.shape
    # Which (particle, part i, occluder j) pairs overlap in the image.
    overlap = ((box[:, :, None, 0] <= box[:, None, :, 2]) & (box[:, None, :, 0] <= box[:, :, None, 2])
               & (box[:, :, None, 1] <= box[:, None, :, 3])
               & (box[:, None, :, 1] <= box[:, :, None, 3]))
    overlap &= ~np.eye(P, dtype=bool)
    for kind, members in (("cone", view.cone_idx), ("ellipsoid", view.ellipsoid_idx)):
        if not len(members):
            continue
        pn, pi, pj = np.nonzero(overlap[:, :, members])          # pj indexes ``members``
        if not len(pn):
            continue
        j_part = members[pj]
        pts = xy[pn, pi]                                           # (pairs, k, 2)
        b = box[pn, j_part]
        inside = ((pts[..., 0] >= b[:, None, 0]) & (pts[..., 0] <= b[:, None, 2])
                  & (pts[..., 1] >= b[:, None, 1]) & (pts[..., 1] <= b[:, None, 3]))
        c_pair, c_pt = np.nonzero(inside)
        if not len(c_pair):
            continue
        cn, ci, cj = pn[c_pair], pi[c_pair], pj[c_pair]
        x = xy[cn, ci, c_pt]
        s = inv_depth[cn, ci, c_pt]
        if kind == "cone":
            a, bb, L, kk = view.cone_shape[cj].T
            depth = cones.ray_cone_depth(view.cone_R[cn, cj], view.cone_t[cn, cj], a, bb, L, kk, x)
            hit = depth * s < 1.0 - DEPTH_MARGIN
        else:
            A, bq, c = view.quadric
            s_occ = conics.ray_quadric_inverse_depth(A[cn, cj], bq[cn, cj], c[cn, cj], x)
            hit = s_occ > s * (1.0 + DEPTH_MARGIN)
        out[cn[hit], ci[hit], c_pt[hit]] = True
    return out
