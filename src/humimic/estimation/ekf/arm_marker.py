"""The Wii remote's marker in the head-camera image (Sugiyama Sec. IV-B): "the marker region is
extracted by hue extraction (0 deg to 20 deg), labeling, and extraction of the labeled region that
has the maximum area. From the extracted marker region, the centroid and the area are
calculated".

Additions, each a parameter: a minimum saturation and value (hue alone takes the skin, whose
hue is about 20 deg, and dark noise), a hue band that may wrap below 0 deg (a red rendered with
noise straddles 0/360), and a region touching the image border is rejected (its area is cut).
The centroid and area are measured in the distorted image and then corrected to the pinhole
model the filter uses: the centroid is undistorted and the area divided by the determinant of
the distortion's Jacobian there.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True)
class MarkerBlob:
    """The largest marker-coloured region of one frame."""

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


def hue_mask(rgb: np.ndarray, hue_deg: tuple[float, float], min_saturation: float,
             min_value: float) -> np.ndarray:
    """uint8 mask (255 inside) of the pixels whose hue lies in ``hue_deg`` (degrees, the lower
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


def largest_region(mask: np.ndarray, min_pixels: int = 1, reject_border: bool = True
                   ) -> tuple[np.ndarray, int, tuple[int, int, int, int]] | None:
    """Centroid (2,), pixel count and bounding box of the largest 8-connected region of
    ``mask`` (None if there is none of at least ``min_pixels``, or it touches the border)."""
    n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h, area = (int(v) for v in stats[k])
    if area < min_pixels:
        return None
    H, W = mask.shape
    if reject_border and (x == 0 or y == 0 or x + w == W or y + h == H):
        return None
    return centroids[k].astype(float), area, (x, y, w, h)


def distortion_area_scale(xy: np.ndarray, K: Intrinsics) -> float:
    """``det d(distorted)/d(undistorted)`` at undistorted normalised ``xy``: a small area there
    is this many times larger in the captured image (radial k1, k2)."""
    r2 = float(xy @ xy)
    s = 1.0 + K.k1 * r2 + K.k2 * r2 * r2
    ds = K.k1 + 2.0 * K.k2 * r2
    return s * (s + 2.0 * ds * r2)


def find_marker(rgb: np.ndarray, K: Intrinsics, hue_deg=(0.0, 20.0), min_saturation=0.5,
                min_value=0.2, min_pixels=4, reject_border=True) -> MarkerBlob | None:
    """The marker's centroid and area in the pinhole model of ``K``, or None."""
    found = largest_region(hue_mask(rgb, hue_deg, min_saturation, min_value), min_pixels,
                           reject_border)
    if found is None:
        return None
    uv_d, pixels, bbox = found
    xy = K.undistort_normalized(uv_d)
    uv = np.array([K.fx * xy[0] + K.cx, K.fy * xy[1] + K.cy])
    return MarkerBlob(uv, pixels / distortion_area_scale(xy, K), uv_d, pixels, bbox)
