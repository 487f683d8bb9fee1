"""Where the wearer's own arm is in the head-camera image, from what the wearer knows.

Features on the moving arm and Wii remote corrupt the SLAM map: they move with the arm, not
the room (Sugiyama & Miura sec. V-B notice it and leave it open: "it might be necessary to use
only the features lying away from the arm region"). The wearer's camera knows three things
about its own arm: the Wii remote's red marker (hue 0-20 deg, the paper's marker extraction,
eq. 13), the marker's size, and the colours of its own skin and sleeve. The mask is

1. the marker: the largest region of marker hue;
2. the remote and the hand around it: the marker region grown by ``hand_scale`` marker radii
   (the remote is ~8 marker radii long, the fist ~5);
3. the forearm and sleeve: skin- and sleeve-coloured connected regions touching (2), kept
   inside the cone that opens downwards from the hand (the arm hangs from a shoulder below the
   head camera, so it never rises above the hand in the image; a skin-toned poster beside the
   hand stays out), or, when the marker is out of view, touching the bottom edge;

grown by a margin so that no feature patch straddles the arm's outline. Colours match by
chromaticity (``rgb / (r + g + b)``), which shading leaves nearly unchanged.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from humimic.estimation.ekf.arm_marker import hue_mask


@dataclass(frozen=True)
class ArmMaskParams:
    body_rgb: tuple[tuple[float, float, float], ...] = ((0.87, 0.67, 0.55), (0.2, 0.3, 0.8))
    """The wearer's skin and sleeve colours (0..1)."""
    marker_hue_deg: tuple[float, float] = (-12.0, 12.0)
    """Marker hue band (deg; the lower bound may be negative to wrap through 0). The paper
    extracts 0-20 deg; a room with orange and brown posters needs the marker's own red."""
    marker_min_saturation: float = 0.75
    marker_min_value: float = 0.75
    marker_min_px: int = 6
    """Smallest marker region taken for the marker (px)."""
    marker_max_radius_px: float = 25.0
    """Largest marker radius (px): a 2 cm sphere held no nearer than 0.2 m."""
    marker_min_fill: float = 0.55
    """A marker region fills at least this much of the disk around its bounding box (a sphere
    looks round; poster details rarely do)."""
    hand_scale: float = 5.0
    """The remote and fist extend this many marker radii around the marker."""
    cone_slope: float = 1.0
    """Half-width growth of the arm's cone per pixel below the hand (1: 90 deg opening)."""
    chroma_tol: float = 0.045
    """Largest chromaticity distance of a body-coloured pixel."""
    min_value: float = 0.12
    """Darker pixels are never body-coloured (shadows have no reliable chromaticity)."""
    min_region_px: int = 40
    """Smallest body-coloured region taken for the arm."""
    margin_px: int = 7
    """The mask is grown by this much (about half a feature patch)."""


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """``rgb / (r + g + b)`` ``(..., 3)`` of an image (uint8 or float)."""
    x = rgb.astype(np.float32)
    return x / np.maximum(x.sum(axis=-1, keepdims=True), 1.0)


#: Colour quantisation of the body-colour look-up table (bits dropped per channel).
LUT_SHIFT = 3


@functools.lru_cache(maxsize=16)
def body_colour_lut(body_rgb: tuple, chroma_tol: float, min_value: float) -> np.ndarray:
    """Boolean ``(32, 32, 32)`` table: is the colour (each channel >> 3, bin centres) one of
    the body colours by chromaticity, and bright enough?"""
    n = 256 >> LUT_SHIFT
    c = (np.arange(n) << LUT_SHIFT) + (1 << LUT_SHIFT) / 2
    grid = np.stack(np.meshgrid(c, c, c, indexing="ij"), axis=-1)
    chroma = chromaticity(grid)
    out = np.zeros((n, n, n), bool)
    for ref in body_rgb:
        r = np.asarray(ref, np.float32)
        d = chroma - r / max(float(r.sum()), 1e-6)
        out |= np.einsum("...i,...i->...", d, d) <= chroma_tol**2
    out &= grid.max(axis=-1) >= 255 * min_value
    out.flags.writeable = False
    return out


def marker_region(rgb: np.ndarray, prm: ArmMaskParams, scale: float = 1.0
                  ) -> np.ndarray | None:
    """The marker (uint8 0/255) or None: hue extraction (:func:`.arm_marker.hue_mask`, the
    arm EKF's), labelling and the largest region (Sugiyama sec. IV-B) among the round ones no
    larger than a marker can look. ``scale``: the image's size relative to the camera's (pixel
    parameters are the camera's)."""
    m = hue_mask(rgb, prm.marker_hue_deg, prm.marker_min_saturation, prm.marker_min_value)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    area = stats[1:, cv2.CC_STAT_AREA].astype(float)
    r = 0.5 * np.maximum(stats[1:, cv2.CC_STAT_WIDTH], stats[1:, cv2.CC_STAT_HEIGHT])
    ok = ((area >= max(prm.marker_min_px * scale * scale, 1.0))
          & (r <= prm.marker_max_radius_px * scale)
          & (area >= prm.marker_min_fill * np.pi * r * r))
    if not ok.any():
        return None
    best = 1 + int(np.argmax(np.where(ok, area, -1.0)))
    return np.where(labels == best, 255, 0).astype(np.uint8)


def body_coloured(rgb: np.ndarray, prm: ArmMaskParams) -> np.ndarray:
    """uint8 mask of the pixels with one of the wearer's body colours (a table look-up)."""
    lut = body_colour_lut(tuple(tuple(c) for c in prm.body_rgb), prm.chroma_tol,
                          prm.min_value)
    q = rgb >> LUT_SHIFT
    return lut[q[..., 0], q[..., 1], q[..., 2]].astype(np.uint8) * 255


def grow(mask: np.ndarray, radius: float) -> np.ndarray:
    """uint8 mask grown by ``radius`` px (Euclidean; a distance transform, not a dilation with
    a large kernel, which costs ~100x more)."""
    dist = cv2.distanceTransform(np.where(mask > 0, 0, 255).astype(np.uint8), cv2.DIST_L2, 3)
    return np.where(dist <= radius, 255, 0).astype(np.uint8)


def arm_mask(rgb: np.ndarray, prm: ArmMaskParams = ArmMaskParams(), scale: float = 1.0
             ) -> np.ndarray:
    """Boolean mask of the wearer's arm and Wii remote in an RGB head-camera image. ``scale``
    is the image's size relative to the camera's: the mask is coarse (grown by a margin), so
    it is computed on a half-size image (``scale=0.5``) and upsampled."""
    h, w = rgb.shape[:2]
    marker = marker_region(rgb, prm, scale)
    if marker is not None:
        radius = np.sqrt(np.count_nonzero(marker) / np.pi)
        seed = grow(marker, prm.hand_scale * radius)
        top = int(np.nonzero(seed.any(axis=1))[0][0])  # the arm hangs below the hand
    else:
        seed = np.zeros((h, w), np.uint8)
        seed[-1, :] = 255  # the arm enters from below
        top = (3 * h) // 4
    body = body_coloured(rgb[top:], prm)  # only where the arm can be
    n, labels, stats, _ = cv2.connectedComponentsWithStats(body, connectivity=8)
    touching = np.unique(labels[(seed[top:] > 0) & (body > 0)])
    keep = [i for i in touching
            if i > 0 and stats[i, cv2.CC_STAT_AREA] >= prm.min_region_px * scale * scale]
    mask = seed if marker is not None else np.zeros_like(seed)
    if keep:
        arm = np.isin(labels, keep)
        if marker is not None:  # the cone below the hand
            xs = np.nonzero(seed.any(axis=0))[0]
            x_m, half = 0.5 * (xs[0] + xs[-1]), 0.5 * (xs[-1] - xs[0])
            yy, xx = np.ogrid[0:h - top, 0:w]
            arm &= np.abs(xx - x_m) <= half + prm.cone_slope * yy
        mask[top:][arm] = 255
    if not mask.any():
        return np.zeros((h, w), bool)
    return grow(mask, prm.margin_px * scale) > 0
