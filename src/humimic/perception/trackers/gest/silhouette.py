"""The silhouette offset GEST corrects its stereo candidates by, for a hand of unknown
orientation.

A skin blob's centroid is the centre of the hand's outline, and the outline of an ellipsoid is
not centred on the image of its centre; triangulating the two outlines' centres misses the
centre by ``x - g(c_L(x), c_R(x))`` (``g`` the triangulation). The part of it that depends on
the ellipsoid's orientation is what GEST's orientation estimate cannot give (50-90 deg RMS
off: the shape cue barely sees it), and applying the estimate's misses by more than it
corrects; the part that does not -- a body off the optical axis images stretched outwards --
is the offset of a sphere (:func:`sphere_offset`). Measured per wide-pair frame, the
candidate's error (mm RMS) uncorrected / with the estimate's offset / with the sphere's / with
the true pose's: menezes_gest_reach seed 3, 11.7 / 10.8 / 10.4 / 9.9; menezes_gest_far with
the person at 0.9 m, seed 6, 7.1 / 7.5 / 6.8 / 4.5; the same with ``n_points: 21``, seed 5,
7.7 / 13.4 / 7.4 / 5.1.
"""

from __future__ import annotations

import numpy as np

from humimic.perception.trackers.gest.likelihood import ellipse_centres
from humimic.perception.trackers.gest.stereo import triangulate_pixels


def sphere_offset(centre: np.ndarray, radius: float, cam_l, cam_r) -> np.ndarray:
    """``x - g(c_L(x), c_R(x))`` (m, base frame) for a sphere of ``radius`` (m) at
    ``centre (3,)``: its centre minus the triangulation of its outlines' centres in the
    cameras ``cam_l``, ``cam_r`` (full-resolution pixels; eq. 15 for the outlines). NaN when
    the sphere is not wholly in front of both cameras."""
    x, y, z = np.asarray(centre, float).tolist()       # (np.r_ costs more than the maths)
    r = float(radius)
    c = ellipse_centres(np.array([[x, y, z, 0.0, 0.0, 0.0, r, r, r]]), [cam_l, cam_r])[0]
    if np.abs(c).max() >= 1e5:                                     # off-image sentinel
        return np.full(3, np.nan)
    return np.array([x, y, z]) - triangulate_pixels(cam_l, cam_r, c[:1], c[1:])[0]


def equivalent_radius(axes: np.ndarray) -> float:
    """The sphere standing in for an ellipsoid of semi-axes ``axes (3,)`` of unknown
    orientation: their root mean square (the mean over orientations of the squared extent
    along any direction)."""
    return float(np.sqrt(np.mean(np.square(axes))))
