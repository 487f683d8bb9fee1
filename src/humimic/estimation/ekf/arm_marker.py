"""The Wii remote's marker in the head-camera image (Sugiyama Sec. IV-B): "the marker region is
extracted by hue extraction (0 deg to 20 deg), labeling, and extraction of the labeled region that
has the maximum area. From the extracted marker region, the centroid and the area are
calculated".

:func:`marker_candidates` does the hue extraction and the labelling and measures every region;
the arm EKF then picks one: the largest (the paper's rule, ``select: largest``) or the one its
prediction expects (``select: predicted``, the default: the wearer's room has red and orange
posters larger than the marker). Additions, each a parameter: a minimum saturation and value
(hue alone takes the skin, whose hue is about 20 deg, and dark noise), a hue band that may wrap
below 0 deg (a red rendered with noise straddles 0/360), regions touching the image border
dropped (their area is cut), and shape tests (a marker's silhouette fills most of its bounding
box; a poster's red print rarely does).

The centroid and area are measured in the captured (distorted) image and corrected to the
pinhole model the filter uses: the centroid is undistorted and the area divided by the
determinant of the distortion's Jacobian there.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True)
class MarkerParams:
    """How marker regions are extracted and which count as a marker."""

    hue_deg: tuple[float, float] = (-10.0, 20.0)
    min_saturation: float = 0.5
    min_value: float = 0.2
    min_pixels: int = 6
    min_fill: float = 0.6
    """Smallest fraction of its bounding box a region must fill (a disc fills 0.79)."""
    max_aspect: float = 2.5
    """Largest ratio of the bounding box's sides."""
    reject_border: bool = True


@dataclass(frozen=True)
class MarkerBlob:
    """One marker-coloured region of a frame."""

    uv: np.ndarray
    """(2,) centroid in undistorted pixels."""
    area: float
    """Area in undistorted pixels^2."""
    uv_distorted: np.ndarray
    """(2,) centroid in the image as captured."""
    pixels: int
    """Pixel count of the region."""
    bbox: tuple[int, int, int, int]
    """x, y, width, height in the captured image."""

    @property
    def fill(self) -> float:
        return self.pixels / float(self.bbox[2] * self.bbox[3])

    @property
    def aspect(self) -> float:
        w, h = self.bbox[2], self.bbox[3]
        return max(w, h) / max(1, min(w, h))


def hue_mask(rgb: np.ndarray, hue_deg: tuple[float, float], min_saturation: float,
             min_value: float) -> np.ndarray:
    """uint8 mask (255 inside) of the pixels whose hue lies in ``hue_deg`` (degrees; the lower
    bound may be negative to wrap through 0) with saturation and value (0..1) at least the
    minima."""
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)  # 8-bit: H in [0, 180) = degrees / 2
    lo_h, hi_h = hue_deg[0] / 2.0, hue_deg[1] / 2.0
    s_min, v_min = int(np.ceil(255 * min_saturation)), int(np.ceil(255 * min_value))
    mask = cv2.inRange(hsv, (max(0, int(np.ceil(lo_h))), s_min, v_min),
                       (int(np.floor(hi_h)), 255, 255))
    if lo_h < 0:
        mask |= cv2.inRange(hsv, (int(np.ceil(180 + lo_h)), s_min, v_min), (179, 255, 255))
    return mask


def distortion_area_scale(xy: np.ndarray, K: Intrinsics) -> float:
    """``det d(distorted)/d(undistorted)`` at undistorted normalised ``xy``: a small area there
    is this many times larger in the captured image (radial k1, k2)."""
    r2 = float(xy @ xy)
    s = 1.0 + K.k1 * r2 + K.k2 * r2 * r2
    ds = K.k1 + 2.0 * K.k2 * r2
    return s * (s + 2.0 * ds * r2)


def marker_candidates(rgb: np.ndarray, K: Intrinsics, prm: MarkerParams = MarkerParams()
                      ) -> list[MarkerBlob]:
    """Every 8-connected marker-coloured region passing the size, border and shape tests,
    largest first, measured in the pinhole model of ``K`` (which carries the distortion)."""
    mask = hue_mask(rgb, prm.hue_deg, prm.min_saturation, prm.min_value)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    H, W = mask.shape
    out = []
    for k in np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1:
        x, y, w, h, pixels = (int(v) for v in stats[k])
        if pixels < prm.min_pixels:
            break
        if prm.reject_border and (x == 0 or y == 0 or x + w == W or y + h == H):
            continue
        blob = _measure(centroids[k], pixels, (x, y, w, h), K)
        if blob.fill >= prm.min_fill and blob.aspect <= prm.max_aspect:
            out.append(blob)
    return out


def _measure(uv_d: np.ndarray, pixels: int, bbox, K: Intrinsics) -> MarkerBlob:
    xy = K.undistort_normalized(np.asarray(uv_d, float))
    uv = np.array([K.fx * xy[0] + K.cx, K.fy * xy[1] + K.cy])
    return MarkerBlob(uv, pixels / distortion_area_scale(xy, K), np.asarray(uv_d, float),
                      pixels, bbox)


def find_marker(rgb: np.ndarray, K: Intrinsics, prm: MarkerParams = MarkerParams()
                ) -> MarkerBlob | None:
    """The largest candidate (the paper's rule), or None."""
    cands = marker_candidates(rgb, K, prm)
    return cands[0] if cands else None
