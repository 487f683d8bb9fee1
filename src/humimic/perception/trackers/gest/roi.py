"""GEST's cue images restricted to a region of interest (speed, not in the paper).

The shape, colour and skin cues of a frame are computed in a box around where the hand can be
(every hand-sized skin blob and the last estimate, padded by the distance transform's cap), not
over the whole image: cropping an image is a shift of the principal point (``cx, cy``), so the
cropped frame is an ordinary :class:`~humimic.sensors.camera_model.CameraImage` and every cue
function works on it unchanged. A contour point outside the box counts as off the image (the
distance transform's cap), as it would at the border of a smaller image; the box is padded by
that cap so that a point near the hand sees the same distance as in the full image.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from humimic.sensors.camera_model import CameraImage


def roi_box(boxes: np.ndarray, width: int, height: int, pad_px: float
            ) -> tuple[int, int, int, int] | None:
    """``(x0, y0, x1, y1)`` (integer pixels, exclusive end) of the union of ``boxes (K, 4)``
    (x, y, w, h) padded by ``pad_px`` and clipped to the image; None when there is no box."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    finite = np.isfinite(b).all(axis=1)
    if not finite.all():
        b = b[finite]
    if len(b) == 0:
        return None
    lo = (b[:, :2].min(axis=0) - pad_px).tolist()              # scalars: np.clip costs more
    hi = (b[:, :2] + b[:, 2:]).max(axis=0).tolist()
    size = (width, height)
    x0, y0 = (int(min(max(math.floor(v), 0), m)) for v, m in zip(lo, size, strict=True))
    x1, y1 = (int(min(max(math.ceil(v + pad_px), 0), m)) for v, m in zip(hi, size, strict=True))
    if x1 - x0 < 2 or y1 - y0 < 2:
        return None
    return x0, y0, x1, y1


def crop_frame(frame: CameraImage, box: tuple[int, int, int, int] | None) -> CameraImage:
    """``frame`` cut to ``box`` with the principal point shifted accordingly (None: as is)."""
    if box is None:
        return frame
    x0, y0, x1, y1 = box
    K = frame.camera.intrinsics
    crop = dataclasses.replace(K, width=x1 - x0, height=y1 - y0, cx=K.cx - x0, cy=K.cy - y0)
    cam = dataclasses.replace(frame.camera, intrinsics=crop)
    return CameraImage(frame.t, cam, np.ascontiguousarray(frame.image[y0:y1, x0:x1]))
