"""The ICU tracker's measurement model (Menezes sec. 5.2.2, Table 4), vectorised over
particles: the head-and-shoulders silhouette by distance transform (eq. 3) fused (eq. 7) with
the colour of two patches, head and torso (eq. 6), against reference histograms updated by
eq. 13 in the tracker."""

from __future__ import annotations

import numpy as np

from humimic.perception.cues.edges import dt_distance, shape_log_likelihood
from humimic.perception.cues.fusion import fuse
from humimic.perception.cues.histograms import (
    HEAD_TORSO_PATCHES,
    QuantizedImage,
    bhattacharyya,
    color_log_likelihood,
    patch_histograms,
)
from humimic.perception.cues.templates import Template

GRID = 8
"""Colour samples per patch side (8 x 8)."""


def log_likelihood(dt: np.ndarray, qimage: QuantizedImage, states: np.ndarray,
                   template: Template, refs: np.ndarray, sigma_s: float, sigma_c: float,
                   cues=("shape", "colour"), dt_origin=(0, 0)) -> np.ndarray:
    """Menezes eq. 7 of eq. 3 (shape, mean DT distance) and eq. 6 (two patches) for states
    ``(N, 3)`` (u, v, head width); ``cues`` chooses which. ``dt`` may cover a region of the
    image only, its pixel (0, 0) at image pixel ``dt_origin`` (x0, y0)."""
    terms = []
    if "shape" in cues:
        pts, _ = template.place(states)
        pts = pts - np.asarray(dt_origin, float)
        terms.append(shape_log_likelihood(dt_distance(dt, pts), sigma_s))  # Menezes eq. 3
    if "colour" in cues:
        hists = patch_histograms(qimage, states, HEAD_TORSO_PATCHES, GRID)
        terms.append(color_log_likelihood(hists, refs, sigma_c))  # Menezes eq. 6
    return fuse(*terms)  # Menezes eq. 7


def colour_distance(qimage: QuantizedImage, state: np.ndarray, refs: np.ndarray,
                    hists: np.ndarray | None = None) -> float:
    """Bhattacharyya distance of one state's colours (``hists``, :func:`references` of the
    state, if computed already) to the references: the larger of the head's and the torso's
    (each the mean over the channels; 0 same, 1 disjoint), so another person's shirt counts
    even under a matching face; a patch wholly off the image (the torso of a tutor close to
    the camera) is left out, 1 if both are."""
    h = references(qimage, state) if hists is None else hists
    d = bhattacharyya(h, refs).mean(axis=1)
    seen = h.sum(axis=(1, 2)) > 0  # a patch wholly off the image (the torso, close up)
    return float(d[seen].max()) if seen.any() else 1.0


def references(qimage: QuantizedImage, state: np.ndarray) -> np.ndarray:
    """Reference histograms ``(2, 3, bins)`` of the patches at one state."""
    return patch_histograms(qimage, np.asarray(state)[None], HEAD_TORSO_PATCHES, GRID)[0]
