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
    """(N, P, 4) ``xmin, ymin, xmax, ymax`` of outlines in normalised coordinates (invalid
    parts get an empty box)."""
    x, y = xy[..., 0], xy[..., 1]
    box = np.stack([x.min(axis=-1), y.min(axis=-1), x.max(axis=-1), y.max(axis=-1)], -1)
    return np.where(valid[..., None], box, [np.inf, np.inf, -np.inf, -np.inf])


def hidden(view: BodyView, xy: np.ndarray, inv_depth: np.ndarray,
           boxes_xy: np.ndarray | None = None) -> np.ndarray:
    """``(N, P, k)`` bool: points ``xy (N, P, k, 2)`` with ``inv_depth (N, P, k)`` on the
    parts' contours are hidden by another part of the same particle."""
    n, P, k = inv_depth.shape
    out = np.zeros(n * P * k, bool)
    valid = view.outline.valid
    box = _boxes(view.outline.xy, valid) if boxes_xy is None else boxes_xy
    # Which (particle, part i, occluder j) pairs overlap in the image.
    overlap = ((box[:, :, None, 0] <= box[:, None, :, 2])
               & (box[:, None, :, 0] <= box[:, :, None, 2])
               & (box[:, :, None, 1] <= box[:, None, :, 3])
               & (box[:, None, :, 1] <= box[:, :, None, 3]))
    overlap &= ~np.eye(P, dtype=bool)
    xy_rows = xy.reshape(n * P, k, 2)
    box_rows = box.reshape(n * P, 4)
    for kind, members in (("cone", view.cone_idx), ("ellipsoid", view.ellipsoid_idx)):
        if not len(members):
            continue
        pn, pi, pj = np.nonzero(overlap[:, :, members])          # pj indexes ``members``
        if not len(pn):
            continue
        pts = np.take(xy_rows, pn * P + pi, axis=0)               # (pairs, k, 2)
        b = np.take(box_rows, pn * P + members[pj], axis=0)
        inside = ((pts[..., 0] >= b[:, None, 0]) & (pts[..., 0] <= b[:, None, 2])
                  & (pts[..., 1] >= b[:, None, 1]) & (pts[..., 1] <= b[:, None, 3]))
        c_pair, c_pt = np.nonzero(inside)
        if not len(c_pair):
            continue
        flat = (pn[c_pair] * P + pi[c_pair]) * k + c_pt            # the points' flat index
        x = np.take(xy.reshape(-1, 2), flat, axis=0)
        s = np.take(inv_depth.reshape(-1), flat)
        occ = pn[c_pair] * len(members) + pj[c_pair]               # the occluders' flat index
        if kind == "cone":
            a, bb, L, kk = view.cone_shape[pj[c_pair]].T
            R = np.take(view.cone_R.reshape(-1, 3, 3), occ, axis=0)
            t = np.take(view.cone_t.reshape(-1, 3), occ, axis=0)
            depth = cones.ray_cone_depth(R, t, a, bb, L, kk, x)
            hit = depth * s < 1.0 - DEPTH_MARGIN
        else:
            A, bq, c = view.quadric
            s_occ = conics.ray_quadric_inverse_depth(
                np.take(A.reshape(-1, 3, 3), occ, axis=0), np.take(bq.reshape(-1, 3), occ, axis=0),
                np.take(c.reshape(-1), occ), x)
            hit = s_occ > s * (1.0 + DEPTH_MARGIN)
        out[flat[hit]] = True
    return out.reshape(n, P, k)
