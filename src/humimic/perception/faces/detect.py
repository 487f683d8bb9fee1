"""Face detection with OpenCV's shipped frontal-face Haar cascade (Viola & Jones; Menezes
sec. 4.2.1) and the 30 x 30 crops the recogniser classifies."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

CASCADES = ("haarcascade_frontalface_default.xml", "haarcascade_frontalface_alt.xml",
            "haarcascade_frontalface_alt2.xml")
CROP_SIZE = 30
"""Side of the crops the eigenfaces are computed on (Menezes sec. 5.2.1)."""


@dataclass(frozen=True)
class DetectorParams:
    """``cv2.CascadeClassifier.detectMultiScale`` settings. Sizes in pixels of the searched
    image; ``upscale`` enlarges the grey image first so faces smaller than the cascade's 24 px
    window can be found (at 4x the cost per upscale factor squared)."""

    cascade: str = "haarcascade_frontalface_default.xml"
    scale_factor: float = 1.1
    min_neighbors: int = 2
    """2 rather than OpenCV's 3: on rendered frontal faces of 24-34 px, 98 % found instead of
    92 % (169 frames), at 6 instead of 1 false detection in 382 frames (``faces/rates.py``)."""
    min_size: int = 20
    max_size: int = 0
    """0: no upper bound."""
    upscale: float = 1.0
    fit_px: int = 0
    """With a size range given to :meth:`FaceDetector.detect`, shrink the image by a whole
    number of pyramid steps (``scale_factor ** -k``: the searched face sizes stay those of the
    unshrunk search) so the smallest searched face is about this many pixels (the cascade's
    window is 24); 0: never shrink. OpenCV steps its window by 1 pixel of the pyramid level
    above a scale of 2 and by 2 below, so a search that starts at large faces costs more than
    the same search shrunk (a 136 px window, faces 44-69 px: 3.5 -> 1.1 ms CPU, the same 30/30
    faces found) -- but the boxes are noisier (centre std 2.9 instead of 2.0 px at 28), and the
    ICU tracker's centre error grew from 3.9 to 4.9 px median on Fig. 10, 3.1 to 6.9 on Fig. 9
    (3 seeds), for 25 % less time per frame."""


class FaceDetector:
    """Frontal faces in an image: boxes ``(n, 4)`` as ``x, y, w, h`` in input pixels."""

    def __init__(self, params: DetectorParams | None = None):
        params = params or DetectorParams()
        if params.cascade not in CASCADES:
            raise ValueError(f"unknown cascade {params.cascade!r}; allowed: "
                             f"{', '.join(CASCADES)}")
        self.params = params
        self._cascade = cv2.CascadeClassifier(cv2.data.haarcascades + params.cascade)
        if self._cascade.empty():
            raise RuntimeError(f"OpenCV could not load {params.cascade}")

    def detect(self, image: np.ndarray, sizes: tuple[float, float] | None = None
               ) -> np.ndarray:
        """Boxes of the faces in an RGB or grey uint8 ``image``; ``sizes`` (min, max) px
        narrows the searched face sizes for this call (a tracker expecting a face of known
        size: fewer scales, much less time; see ``fit_px``)."""
        p = self.params
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        lo, hi = sizes if sizes is not None else (p.min_size, p.max_size)
        lo = max(lo, p.min_size)
        s = p.upscale
        k = 0
        if sizes is not None and p.fit_px > 0:
            k = int(np.floor(np.log(lo * s / p.fit_px) / np.log(p.scale_factor)))
        if k > 0:  # shrink by whole pyramid steps: the same face sizes as unshrunk
            s = p.upscale * p.scale_factor ** -k
            grey = cv2.resize(grey, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        elif s != 1.0:
            grey = cv2.resize(grey, None, fx=s, fy=s, interpolation=cv2.INTER_LINEAR)
        boxes = self._cascade.detectMultiScale(
            grey, scaleFactor=p.scale_factor, minNeighbors=p.min_neighbors,
            minSize=(round(lo * s),) * 2,
            maxSize=(round(hi * s),) * 2 if hi else (0, 0))
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        return boxes / s


def box_centers(boxes: np.ndarray) -> np.ndarray:
    """Centres ``(n, 2)`` of boxes ``(n, 4)`` ``x, y, w, h``."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return b[:, :2] + b[:, 2:] / 2.0


def face_mask(size: int = CROP_SIZE, axes: tuple[float, float] = (0.30, 0.40)) -> np.ndarray:
    """Elliptical mask ``(size, size)`` bool of the inner face in a detector box (semi-axes as
    fractions of the side): the box's corners hold hair, ears and background."""
    c = (size - 1) / 2.0
    yy, xx = np.mgrid[0:size, 0:size]
    return ((xx - c) / (axes[0] * size)) ** 2 + ((yy - c) / (axes[1] * size)) ** 2 <= 1.0


_MASK = face_mask()


def raw_crops(image: np.ndarray, boxes: np.ndarray, size: int = CROP_SIZE) -> np.ndarray:
    """Grey ``(n, size, size)`` uint8 crops of boxes ``(n, 4)``, resized with area
    interpolation (boxes are clipped to the image)."""
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    h, w = grey.shape
    out = np.zeros((len(boxes), size, size), np.uint8)
    for i, (x, y, bw, bh) in enumerate(np.asarray(boxes, dtype=np.float64).reshape(-1, 4)):
        x0, y0 = int(round(max(x, 0))), int(round(max(y, 0)))
        x1, y1 = int(round(min(x + bw, w))), int(round(min(y + bh, h)))
        patch = grey[y0:max(y1, y0 + 1), x0:max(x1, x0 + 1)]
        out[i] = cv2.resize(patch, (size, size), interpolation=cv2.INTER_AREA)
    return out


def equalize(crops: np.ndarray, mask: np.ndarray | None = _MASK, blur_sigma: float = 0.7
             ) -> np.ndarray:
    """Histogram equalisation (``cv2.equalizeHist``) of each crop over the pixels of ``mask``
    (outside it the crop is 0; ``mask=None``: the whole crop), after a slight Gaussian blur
    against pixel noise (``blur_sigma`` px; 0: none)."""
    out = np.zeros_like(crops)
    for i, c in enumerate(crops):
        if blur_sigma > 0:
            c = cv2.GaussianBlur(c, (0, 0), blur_sigma)
        if mask is None:
            out[i] = cv2.equalizeHist(c)
        else:
            out[i][mask] = cv2.equalizeHist(np.ascontiguousarray(c[mask])[:, None])[:, 0]
    return out


def crop_faces(image: np.ndarray, boxes: np.ndarray, size: int = CROP_SIZE,
               mask: np.ndarray | None = _MASK) -> np.ndarray:
    """The recogniser's input: crops of the boxes resized to ``size`` and histogram-equalised
    (the pre-processing Menezes found best, Fig. 7) over the inner-face ``mask`` (default
    :func:`face_mask`). Measured on held-out renders (10 known people, 6 strangers, yaw up to
    25 deg): equalising the whole box recognised 59 % at 2 % false acceptance, equalising the
    inner face (and leaving the rest out) 95 %."""
    return equalize(raw_crops(image, boxes, size), mask)


def matches_truth(boxes: np.ndarray, center_px: np.ndarray, size_px: float,
                  tolerance: float = 0.5) -> np.ndarray:
    """Which boxes lie on a face at ``center_px`` of width ``size_px``: centre within
    ``tolerance * size`` and width within a factor 2 of the face's."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    d = np.linalg.norm(box_centers(b) - np.asarray(center_px), axis=1)
    ratio = b[:, 2] / size_px
    return (d < tolerance * size_px) & (ratio > 0.5) & (ratio < 2.0)
