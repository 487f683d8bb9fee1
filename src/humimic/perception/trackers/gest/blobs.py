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

import cv2
import numpy as np

from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.importance import Blobs, skin_blobs

GROW = 0.5
"""Margin (times the subsampled blob's larger side) the box a blob is re-measured in grows by
when the blob's component reaches the box's edge."""


def hand_blobs(image: np.ndarray, lut: ColorLUT, subsample: int = 2,
               threshold: float = 0.5, min_area_px: float = 40.0) -> Blobs:
    """Skin blobs of an RGB ``image`` (``lut``'s posterior above ``threshold``) of at least
    ``min_area_px`` (full-resolution px), found at ``subsample`` and measured at full
    resolution (module docstring)."""
    s = int(subsample)
    small = image[::s, ::s]                      # a view: the posterior is per pixel
    coarse = skin_blobs(lut.mask(small, threshold), 1,
                        min_area_px=min_area_px / (s * s))
    if len(coarse.areas) == 0:
        return coarse
    h, w = image.shape[:2]
    centres, boxes, areas = [], [], []
    for x, y, bw, bh in coarse.boxes:
        ix0, iy0 = max(int(x * s) - s, 0), max(int(y * s) - s, 0)
        ix1, iy1 = min(int((x + bw) * s) + s, w), min(int((y + bh) * s) + s, h)
        pad = 0
        while True:                     # grow the box while the component reaches its edge
            x0, y0 = max(ix0 - pad, 0), max(iy0 - pad, 0)
            x1, y1 = min(ix1 + pad, w), min(iy1 + pad, h)
            mask = lut.mask(image[y0:y1, x0:x1], threshold)
            n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
            inner = np.bincount(labels[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0].ravel(),
                                minlength=n)
            inner[0] = 0
            k = int(np.argmax(inner))
            bx, by, cw, ch = (int(v) for v in stats[k, :4])
            cut = ((bx == 0 < x0) or (by == 0 < y0) or (bx + cw == x1 - x0 and x1 < w)
                   or (by + ch == y1 - y0 and y1 < h))
            if not cut or pad >= GROW * max(bw, bh) * s or inner[k] == 0:
                break
            pad = int(np.ceil(GROW * max(bw, bh) * s))
        if inner[k] == 0:
            continue
        bx, by, cw, ch = (int(v) for v in stats[k, :4])
        box = [bx + x0, by + y0, cw, ch]
        if box in boxes:                # one component seen as two coarse blobs
            continue
        centre, area = hull_moments(labels[by:by + ch, bx:bx + cw] == k)
        centres.append(centre + (x0 + bx, y0 + by))
        boxes.append(box)
        areas.append(area)
    return Blobs(np.reshape(centres, (-1, 2)), np.reshape(boxes, (-1, 4)), np.asarray(areas,
                                                                                     float))


def hull_moments(component: np.ndarray) -> tuple[np.ndarray, float]:
    """Centroid ``(u, v)`` (px, pixel centres at integer coordinates) and area (px) of the
    pixels of a binary ``component (h, w)`` and those whose centres lie in its convex hull
    (module docstring): a blob without holes or notches keeps its own pixels (rasterising
    the hull with ``cv2.fillConvexPoly`` adds a rim on one side; the hull polygon's own
    centroid follows its few corner pixels, 0.12 px RMS against the pixels' 0.08 on
    menezes_gest_reach). The pixels in the hull are counted by Pick's theorem first (area plus
    half the boundary's lattice points plus one): when the blob has them all, it is used as
    it is."""
    comp = component.astype(np.uint8)
    contours, _ = cv2.findContours(comp, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hull_px = cv2.convexHull(np.concatenate(contours))[:, 0]                   # (H, 2) int
    step = np.abs(np.roll(hull_px, -1, axis=0) - hull_px)
    in_hull = cv2.contourArea(hull_px) + np.gcd(step[:, 0], step[:, 1]).sum() / 2 + 1  # Pick
    m = cv2.moments(comp, binaryImage=True)
    if m["m00"] < round(in_hull):                     # pixels to add (else: the common case)
        a = hull_px.astype(float)
        b = np.roll(a, -1, axis=0)  # edges a -> b
        rows = np.arange(comp.shape[0], dtype=float)[:, None]  # (h, 1)
        lo, hi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
        meets = (rows >= lo - 1e-9) & (rows <= hi + 1e-9)  # (h, H)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(hi > lo, (rows - a[:, 1]) / (b[:, 1] - a[:, 1]), 0.0)
        x = a[:, 0] + t * (b[:, 0] - a[:, 0])  # row meets edge
        x_b = np.where(hi > lo, x, b[:, 0])  # flat: both ends
        left = np.minimum(np.where(meets, x, np.inf), np.where(meets, x_b, np.inf)).min(axis=1)
        right = np.maximum(np.where(meets, x, -np.inf), np.where(meets, x_b, -np.inf)).max(axis=1)
        u = np.arange(comp.shape[1], dtype=float)
        inside = (u >= left[:, None] - 1e-9) & (u <= right[:, None] + 1e-9)
        m = cv2.moments(comp | inside.astype(np.uint8), binaryImage=True)
    return np.array([m["m10"], m["m01"]]) / m["m00"], float(m["m00"])
