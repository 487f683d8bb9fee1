"""GEST's cue images restricted to a region of interest (speed, not in the paper).

The shape, colour and skin cues of a frame are computed in a box around where the hand can be
(every hand-sized skin blob and the last estimate, padded by ``cue_pad_px``), not over the
whole image: cropping an image is a shift of the principal point (``cx, cy``), so the cropped
frame is an ordinary :class:`~humimic.sensors.camera_model.CameraImage` and every cue function
works on it unchanged. A contour point outside the box counts as off the image (the distance
transform's cap), as it would at the border of a smaller image; the pad makes a point near the
hand see the same distance as in the full image up to the pad (any edge that near is in the
box), and at least the pad beyond.

A hand that images large (the foveal pair) is seen in the box averaged over ``k x k`` pixel
blocks (``foveal_cue_radius_px`` in the foveal pair, ``cue_radius_px`` in the wide one): a
change of the intrinsics too (``f / k``, ``(c + 0.5) / k - 0.5``), so the cues work on it
unchanged, at a cost bounded by the hand's size in blocks.
"""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np

from humimic.sensors.camera_model import CameraImage


def roi_box(boxes: np.ndarray, width: int, height: int, pad_px: float
            ) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` (integer pixels, exclusive end) of the union of ``boxes (K, 4)``
    (x, y, w, h) padded by ``pad_px`` and clipped to the image; None when there is no box."""
    # Python floats, not numpy: the union of a few boxes costs a tenth of numpy's calls
    b = [r for r in np.asarray(boxes, float).reshape(-1, 4).tolist()
         if all(math.isfinite(v) for v in r)]
    if len(b) == 0:
        return None
    lo = (min(r[0] for r in b) - pad_px, min(r[1] for r in b) - pad_px)
    hi = (max(r[0] + r[2] for r in b), max(r[1] + r[3] for r in b))
    size = (width, height)
    x0, y0 = (int(min(max(math.floor(v), 0), m)) for v, m in zip(lo, size, strict=True))
    x1, y1 = (int(min(max(math.ceil(v + pad_px), 0), m)) for v, m in zip(hi, size, strict=True))
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    return x0, y0, x1, y1


def crop_frame(frame: CameraImage, box: tuple[int, int, int, int] | None, k: int = 1
               ) -> CameraImage:
    """``frame`` cut to ``box`` with the principal point shifted accordingly (None: as is),
    then with ``k > 1`` averaged over ``k x k`` blocks (the box trimmed to whole blocks;
    :meth:`~humimic.sensors.camera_model.Intrinsics.decimated`)."""
    if box is None and k == 1:
        return frame
    K = frame.camera.intrinsics
    x0, y0, x1, y1 = (0, 0, K.width, K.height) if box is None else box
    if k > 1:
        x1, y1 = x0 + max(1, (x1 - x0) // k) * k, y0 + max(1, (y1 - y0) // k) * k
    crop = dataclasses.replace(K, width=x1 - x0, height=y1 - y0, cx=K.cx - x0, cy=K.cy - y0)
    image = np.ascontiguousarray(frame.image[y0:y1, x0:x1])
    if k > 1:
        crop = crop.decimated(k)
        image = cv2.resize(image, (crop.width, crop.height), interpolation=cv2.INTER_AREA)
    cam = frame.camera.with_intrinsics(crop)
    return CameraImage(frame.t, cam, image)


def decimated_camera(camera, k: int):
    """``camera`` with its intrinsics decimated by ``k`` (as is for 1)."""
    if k == 1:
        return camera
    return camera.with_intrinsics(camera.intrinsics.decimated(k))


def to_view_px(uv: np.ndarray, origin: np.ndarray, k: int = 1) -> np.ndarray:
    """Full-image pixels ``uv (..., 2)`` in the :func:`crop_frame` of corner ``origin`` and
    block ``k``."""
    return uv - origin if k == 1 else (uv - origin + 0.5) / k - 0.5


def to_full_px(uv: np.ndarray, origin: np.ndarray, k: int = 1) -> np.ndarray:
    """:func:`to_view_px`'s inverse."""
    return uv + origin if k == 1 else (uv + 0.5) * k - 0.5 + origin


def decimation(radius_px: float, budget_px: float | None) -> int:
    """The block size ``k`` that brings a hand image of ``radius_px`` down to between
    ``budget_px`` and twice that (1: no budget, or the hand no larger than it)."""
    if budget_px is None or not math.isfinite(radius_px):
        return 1
    return max(1, int(radius_px // budget_px))
