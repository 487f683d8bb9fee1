"""Importance functions from detectors (Menezes sec. 4.2): where to put particles.

* eq. 8 -- :func:`detection_proposal`: a Gaussian mixture centred on the ``N_B`` detections
  (faces from the Haar cascade, skin blobs), ``sum_i N(x; p_i, diag(sigma_u^2, sigma_v^2))``;
  with detected sizes the mixture also covers the state's scale.
* eq. 9 -- :func:`mixed_proposal`: the detectors' functions averaged, ``(1/M) sum_j pi_j``
  (a detector that found nothing drops out).
* eq. 12 -- :func:`recognition_proposal`: the faces' components weighted by the recognition
  probability ``P(C_l|F_i)`` of the target's class (faces of other people drop out).
* :func:`skin_blobs` -- skin-coloured blobs (sec. 4.2.2): the skin mask subsampled, grouped
  into connected components, filtered by area and aspect ratio.

The densities are :mod:`humimic.estimation.particles.densities` objects, ready for
ICONDENSATION.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.estimation.particles.densities import GaussianMixture, Mixture


def detection_proposal(centers: np.ndarray, sigma_uv=(6.0, 6.0), sizes: np.ndarray | None = None,
                       sigma_s: float | None = None, weights: np.ndarray | None = None
                       ) -> GaussianMixture:
    """Menezes eq. 8 over ``(u, v)``, or over ``(u, v, s)`` when ``sizes`` (the state's scale
    for each detection) and ``sigma_s`` are given. ``weights`` None: equal (eq. 8)."""
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    sig = np.asarray(sigma_uv, dtype=np.float64)
    if sizes is not None:
        if sigma_s is None:
            raise ValueError("sizes given without sigma_s")
        c = np.column_stack([c, np.asarray(sizes, dtype=np.float64).reshape(-1)])
        sig = np.append(sig, sigma_s)
    return GaussianMixture(c, np.broadcast_to(sig, c.shape), weights)  # Menezes eq. 8


def recognition_proposal(centers: np.ndarray, probabilities: np.ndarray, sigma_uv=(6.0, 6.0),
                         sizes: np.ndarray | None = None, sigma_s: float | None = None
                         ) -> GaussianMixture:
    """Menezes eq. 12: the face detections weighted by ``P(C_l|F_i)`` (the tracked person's
    class); faces with probability 0 (the void class or someone else) are left out."""
    return detection_proposal(centers, sigma_uv, sizes, sigma_s,
                              np.asarray(probabilities, dtype=np.float64))  # Menezes eq. 12


def mixed_proposal(*proposals) -> Mixture:
    """Menezes eq. 9: ``(1/M) sum_j pi(x|z^j)`` over the detectors that found something."""
    return Mixture(tuple(proposals))  # Menezes eq. 9


@dataclass(frozen=True)
class Blobs:
    """Connected skin regions: centroids ``(K, 2)`` (u, v), boxes ``(K, 4)`` (x, y, w, h) and
    areas ``(K,)``, in full-image pixels."""

    centers: np.ndarray
    boxes: np.ndarray
    areas: np.ndarray


def skin_blobs(mask: np.ndarray, subsample: int = 2, min_area_px: float = 40.0,
               aspect: tuple[float, float] = (0.25, 4.0)) -> Blobs:
    """Skin blobs of a binary (or 0..255) skin mask: subsampled by ``subsample``, grouped by
    ``cv2.connectedComponentsWithStats`` (8-connected), kept if their area (full-resolution
    px) is at least ``min_area_px`` and their box's height/width ratio within ``aspect``."""
    m = np.asarray(mask)
    if m.dtype != np.uint8:          # a uint8 mask (0/1 or 0/255) is labelled as it is
        m = (m > 0).astype(np.uint8)
    if subsample > 1:
        m = m[::subsample, ::subsample]
    n, _, stats, cent = cv2.connectedComponentsWithStats(m, connectivity=8)
    stats, cent = stats[1:].astype(np.float64), cent[1:]
    s = float(subsample)
    area = stats[:, cv2.CC_STAT_AREA] * s * s
    w, h = stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]
    ratio = h / np.maximum(w, 1.0)
    keep = (area >= min_area_px) & (ratio >= aspect[0]) & (ratio <= aspect[1])
    # a subsampled pixel i stands for full-resolution pixels [s i, s i + s): centre s i + (s-1)/2
    centers = cent[keep] * s + (s - 1.0) / 2.0
    boxes = stats[keep, :4] * s                       # x, y, w, h (CC_STAT_LEFT..HEIGHT)
    return Blobs(centers.reshape(-1, 2), boxes.reshape(-1, 4), area[keep])
