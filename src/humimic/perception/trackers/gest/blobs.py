"""GEST's skin blobs: found on a subsampled skin mask, measured at full resolution.

The importance function needs hand blobs' centroids to a tenth of a pixel (their disparity is
the depth: 0.1 px is 9 mm at 0.9 m), which the subsampled mask of sec. 4.2.2 does not give
(the nearest triangulated blob is 23 mm RMS from the hand subsampled by 2, 10 mm at full
resolution, menezes_gest_reach at 1.2 m). Labelling the full-resolution mask costs twice the
rest of the frame's skin work, so the blobs are found on a ``subsample``-d skin posterior
(:func:`~humimic.perception.cues.importance.skin_blobs`) and each is re-measured in its box
(grown by ``subsample`` px) at full resolution: the largest connected component there gives
the centroid, the box and the area.
"""

from __future__ import annotations

import cv2
import numpy as np

from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.importance import Blobs, skin_blobs

GROW = 0.5
"""Margin (times the subsampled blob's larger side) of the box a blob is re-measured in."""


def hand_blobs(image: np.ndarray, lut: ColorLUT, subsample: int = 2,
               threshold: float = 0.5, min_area_px: float = 40.0) -> Blobs:
    """Skin blobs of an RGB ``image`` (``lut``'s posterior above ``threshold``) of at least
    ``min_area_px`` (full-resolution px), found at ``subsample`` and measured at full
    resolution (module docstring)."""
    s = int(subsample)
    small = image[::s, ::s]                      # a view: the posterior is per pixel
    coarse = skin_blobs((lut.posterior(small) > threshold).astype(np.uint8), 1,
                        min_area_px=min_area_px / (s * s))
    if len(coarse.areas) == 0:
        return coarse
    h, w = image.shape[:2]
    centres, boxes, areas = [], [], []
    for x, y, bw, bh in coarse.boxes:
        ix0, iy0 = max(int(x * s) - s, 0), max(int(y * s) - s, 0)
        ix1, iy1 = min(int((x + bw) * s) + s, w), min(int((y + bh) * s) + s, h)
        pad = int(np.ceil(GROW * max(bw, bh) * s))
        x0, y0, x1, y1 = max(ix0 - pad, 0), max(iy0 - pad, 0), min(ix1 + pad, w), min(iy1 + pad, h)
        mask = (lut.posterior(image[y0:y1, x0:x1]) > threshold).astype(np.uint8)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        inner = np.bincount(labels[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0].ravel(), minlength=n)
        inner[0] = 0
        k = int(np.argmax(inner))
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
    convex hull of a binary ``component (h, w)``'s pixels (module docstring): the centroid
    of the hull polygon through the outer pixels' centres (Green's theorem; rasterising the
    hull adds pixels on one side), the area as about the pixels it covers (Pick's theorem with
    the perimeter for the boundary pixels, ``A + P / 2 + 1``: 3 % high on a 500-px ellipse);
    the pixels' own if the hull is a line."""
    comp = component.astype(np.uint8)
    contours, _ = cv2.findContours(comp, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hull = cv2.convexHull(np.concatenate(contours))
    m = cv2.moments(hull)
    if m["m00"] <= 0.0:
        m = cv2.moments(comp, binaryImage=True)
        return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]), float(m["m00"])
    area = m["m00"] + 0.5 * cv2.arcLength(hull, True) + 1.0
    return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]), float(area)
