"""Rasterise one particle's projected body model (tests, visualisation, region cues).

A pixel is filled when its centre (integer coordinates, :mod:`humimic.sensors.camera_model`)
is inside the polygon, as OpenGL rasterises (``skimage.draw.polygon``). ``cv2.fillPoly`` is not
used: it also fills the pixels its boundary crosses, a ~0.5 px dilation (a disc of radius
10 px: 350 px filled against 317 pixel centres inside).
"""

from __future__ import annotations

import numpy as np
from skimage.draw import polygon as draw_polygon

from humimic.bodymodel.projection import BodyView


def fill(mask: np.ndarray, polygons: np.ndarray, value: int) -> np.ndarray:
    """Fill polygons ``(K, V, 2)`` (pixels; rows with NaN are skipped) into ``mask``."""
    polygons = np.asarray(polygons, float).reshape((-1,) + np.shape(polygons)[-2:])
    for poly in polygons:
        if np.isfinite(poly).all():
            rows, cols = draw_polygon(poly[:, 1], poly[:, 0], mask.shape[:2])
            mask[rows, cols] = value
    return mask


def part_masks(view: BodyView, i: int = 0) -> np.ndarray:
    """``(P, H, W)`` bool: each part's whole silhouette for particle ``i`` (occlusion ignored)."""
    intr = view.intrinsics
    out = np.zeros((len(view.part_names), intr.height, intr.width), np.uint8)
    for p in range(len(view.part_names)):
        fill(out[p], view.outline.uv[i, p][None], 1)
    return out.astype(bool)


def label_mask(view: BodyView, i: int = 0) -> np.ndarray:
    """``(H, W)`` uint8 labels for particle ``i``: 0 background, ``p + 1`` where part ``p`` is
    the nearest. Parts are painted far to near by their outline's mean depth (the painter's
    order: exact for parts that do not interpenetrate)."""
    intr = view.intrinsics
    mask = np.zeros((intr.height, intr.width), np.uint8)
    o = view.outline
    with np.errstate(invalid="ignore", divide="ignore"):
        depth = np.where(o.valid[i], 1.0 / np.mean(o.inv_depth[i], axis=-1), -np.inf)
    for p in np.argsort(-depth):
        if o.valid[i, p]:
            fill(mask, o.uv[i, p][None], p + 1)
    return mask
