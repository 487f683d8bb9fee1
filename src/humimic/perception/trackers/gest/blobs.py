"""GEST's skin blobs: found on a subsampled skin mask, measured at full resolution.

The importance function needs hand blobs' centroids to a tenth of a pixel (their disparity is
the depth: 0.1 px is 9 mm at 0.9 m), which the subsampled mask of sec. 4.2.2 does not give
(the nearest triangulated blob is 23 mm RMS from the hand subsampled by 2, 10 mm at full
resolution, menezes_gest_reach at 1.2 m). Labelling the full-resolution mask costs twice the
rest of the frame's skin work, so the blobs are found on a ``subsample``-d skin posterior
(:func:`~humimic.perception.cues.importance.skin_blobs`) and each is re-measured in its box
(grown by ``subsample`` px) at full resolution: the connected component with the most pixels
in that box gives the box, and its convex hull the centroid and the area
(:func:`hull_moments`). When the component reaches the box's edge it is labelled again in a
box grown by ``GROW`` times the blob's size: thin parts of the mask (a lit hand's rim around
its highlight) vanish in the subsampled mask, and a box around the rest cut them off (a
0.6 px centroid error, 46 mm of depth in the wide eyes at 0.85 m).

The hull, not the component: GEST's hand is an ellipsoid, whose image is an ellipse (convex),
and the stereo cue compares the centroids with the projected ellipses' centres. A lit hand's
highlight (the red channel saturating) can fall outside the skin model and bite holes and
notches into the mask, different ones in the two eyes: menezes_gest_far with the person at
0.9 m (hand 0.5-0.9 m from the eyes), seed 5, the wide pair's components kept 38-77 % of the
hand's pixels, their centroids 1-2.7 px from the ellipse centres (disparity errors of 0.3-0.5
px, 2-4 cm of depth); the blobs triangulated 25.5 mm RMS (183 max) from the hand in the wide
pair, 6.4 (20) in the foveal one, from their hulls 6.8 (14) and 5.4 (7.2). With the lit skin
in the skin model too (``skin_gains``), the hulls' centroids are 0.04-0.08 px RMS from the
ellipse centres per eye where the components' are 0.06-0.15 (wide) and 0.29-0.71 (foveal).
"""

from __future__ import annotations

import numpy as np

from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.importance import Blobs
from humimic.perception.trackers.gest.components import hull_sums, measure_blobs

GROW = 0.5
"""Margin (times the subsampled blob's larger side) the box a blob is re-measured in grows by
when the blob's component reaches the box's edge."""

ASPECT = (0.25, 4.0)
"""The subsampled blobs' box height/width range
(:func:`~humimic.perception.cues.importance.skin_blobs`' default)."""


def hand_blobs(image: np.ndarray, lut: ColorLUT, subsample: int = 2,
               threshold: float = 0.5, min_area_px: float = 40.0,
               box: tuple[int, int, int, int] | None = None) -> Blobs:
    """Skin blobs of an RGB ``image`` (``lut``'s posterior above ``threshold``) of at least
    ``min_area_px`` (full-resolution px), found at ``subsample`` and measured at full
    resolution (module docstring; compiled: :func:`.components.measure_blobs`); with ``box``
    ``(x0, y0, x1, y1)`` those of ``image[y0:y1, x0:x1]`` (the box clipped to the
    image), in its pixels (the kernel reads the whole image: one compiled version for
    all boxes)."""
    s = int(subsample)
    h, w = image.shape[:2]
    x0, y0, x1, y1 = (0, 0, w, h) if box is None else box
    x0, x1 = min(max(int(x0), 0), w), min(max(int(x1), 0), w)      # the kernel reads unchecked
    y0, y1 = min(max(int(y0), 0), h), min(max(int(y1), 0), h)
    x1, y1 = max(x1, x0), max(y1, y0)
    centres, boxes, areas, coarse = measure_blobs(
        image, y0, x0, y1 - y0, x1 - x0, lut.mask_table(threshold), lut.bits, s,
        min_area_px / (s * s), ASPECT[0], ASPECT[1], GROW)
    if len(areas) == 0:
        return Blobs(np.zeros((0, 2)), np.zeros((0, 4)), np.zeros(0))
    return Blobs(centres, boxes, areas)


def hull_moments(component: np.ndarray) -> tuple[np.ndarray, float]:
    """Centroid ``(u, v)`` (px, pixel centres at integer coordinates) and area (px) of the
    pixels of a binary ``component (h, w)`` and those whose centres lie in its convex hull
    (module docstring): a blob without holes or notches keeps its own pixels (rasterising
    the hull with ``cv2.fillConvexPoly`` adds a rim on one side; the hull polygon's own
    centroid follows its few corner pixels, 0.12 px RMS against the pixels' 0.08 on
    menezes_gest_reach). The pixels in the hull are counted by Pick's theorem first (area plus
    half the boundary's lattice points plus one): when the blob has them all, it is used as
    it is. Compiled: :func:`.components.hull_sums`."""
    labels = np.ascontiguousarray(component, dtype=np.int32)
    m00, m10, m01 = hull_sums(labels, 1, 0, labels.shape[0], 0, labels.shape[1])
    return np.array([m10, m01]) / m00, float(m00)
