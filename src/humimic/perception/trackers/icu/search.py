"""Where the ICU tracker looks, so that face detection every frame stays cheap.

* :func:`skin_windows` -- while searching (nobody tracked): the Haar cascade runs only around
  the skin blobs of head size (Menezes sec. 4.2.2's skin blobs gate sec. 4.2.1's detector),
  each window at face sizes scaled from its blob, instead of over the whole frame at every
  size (measured at 320 x 240: ~16 ms CPU whole frame, ~1 ms per head window).
* :func:`shape_roi` -- while tracking: the image region whose edges and distance transform the
  shape cue (eq. 3) needs: the particle cloud's template extent plus a margin; contour points
  outside it read the distance transform's cap, as points off the image do.
"""

from __future__ import annotations

import numpy as np

from humimic.perception.faces.detect import box_centers

FACE_PER_BLOB = (0.6, 1.6)
"""Face-box widths searched around a skin blob, per blob width (measured on the rendered heads:
face box / skin blob ~1.05-1.15; hair, a turned head or a hand joining the blob move it)."""
BLOB_ASPECT = (0.5, 3.0)
"""Height / width of a head's skin blob (face and neck: ~1.35)."""
GROW = 0.5
"""A blob's window is its box grown by this many blob widths on every side."""
MAX_WINDOWS = 4
"""At most this many blobs (the largest) are searched per frame: the cost is bounded."""


def skin_windows(blob_boxes: np.ndarray, width: int, height: int, min_face_px: float,
                 max_windows: int = MAX_WINDOWS
                 ) -> list[tuple[tuple[int, int, int, int], tuple[float, float]]]:
    """Search windows ``(x0, y0, x1, y1)`` and face sizes ``(min, max)`` px for skin blobs
    ``(K, 4)`` (x, y, w, h): blobs of a head's shape whose largest face would reach
    ``min_face_px``, largest first."""
    b = np.asarray(blob_boxes, float).reshape(-1, 4)
    ratio = b[:, 3] / np.maximum(b[:, 2], 1.0)
    ok = ((ratio >= BLOB_ASPECT[0]) & (ratio <= BLOB_ASPECT[1])
          & (FACE_PER_BLOB[1] * b[:, 2] >= min_face_px))
    b = b[ok][np.argsort(-(b[ok, 2] * b[ok, 3]), kind="stable")][:max_windows]
    out = []
    for x, y, w, h in b:
        g = GROW * w
        x0, y0 = int(max(0, x - g)), int(max(0, y - g))
        x1, y1 = int(min(width, x + w + g)), int(min(height, y + h + g))
        lo, hi = max(min_face_px, FACE_PER_BLOB[0] * w), FACE_PER_BLOB[1] * w
        if x1 - x0 >= lo and y1 - y0 >= lo:
            out.append(((x0, y0, x1, y1), (lo, hi)))
    return out


def unique_boxes(boxes: np.ndarray, overlap: float = 0.5) -> np.ndarray:
    """Boxes ``(K, 4)`` less those whose centre lies within ``overlap`` widths of an earlier
    kept box's (the same face found from two overlapping windows)."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    c = box_centers(b)
    keep: list[int] = []
    for i in range(len(b)):
        if all(np.hypot(*(c[i] - c[j])) >= overlap * max(b[i, 2], b[j, 2]) for j in keep):
            keep.append(i)
    return b[keep]


def shape_roi(states: np.ndarray, extent: np.ndarray, width: int, height: int, pad: float
              ) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)``: the box holding the template placed at every state ``(N, 3)``
    (u, v, s) -- ``extent`` ``(2, 2)`` the template's (min, max) corner in head widths --
    grown by ``pad`` px and clipped to the image (at least 1 px)."""
    x = np.asarray(states, float)
    lo = (x[:, :2] + x[:, 2:3] * extent[0]).min(axis=0) - pad
    hi = (x[:, :2] + x[:, 2:3] * extent[1]).max(axis=0) + pad
    x0, y0 = int(np.clip(np.floor(lo[0]), 0, width - 1)), int(np.clip(np.floor(lo[1]), 0,
                                                                         height - 1))
    x1, y1 = int(np.clip(np.ceil(hi[0]), x0 + 1, width)), int(np.clip(np.ceil(hi[1]), y0 + 1,
                                                                        height))
    return x0, y0, x1, y1
