"""The orientation of a weighted set of hand ellipsoids (GEST's published pose).

An ellipsoid looks the same after a half turn about any of its axes (:data:`FLIPS`), and its
yaw, pitch and roll wrap, so the weighted mean of the particles' angles (the filter's generic
MMSE, Menezes Table 1 step 7) is no orientation at all once the particles straddle a wrap or
a symmetry: measured on a dark-skinned hand, it came out 60-90 deg from every particle, its
outline off the hand, and the tracker declared the hand lost on a third of the frames it
followed to within 6 mm. :func:`mean_orientation` instead turns every particle by the half turn
that brings it nearest the heaviest one and takes the chordal L2 mean of the rotations (the
weighted sum of the matrices projected onto SO(3), as ``scipy.spatial.transform.Rotation.mean``
defines it). Centre and semi-axes keep their weighted means (a half turn permutes no axis).
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.avatar import ypr_from_matrix
from humimic.bodymodel.kinematics import ypr_matrix
from humimic.estimation.particles import normalize
from humimic.perception.trackers.gest.kernels import FLIP_SIGNS, flipped_rotation_sum

#: The ellipsoid's proper symmetries (half turns about its axes).
FLIPS = np.array([np.diag(d) for d in FLIP_SIGNS], float)


def mean_orientation(ypr: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    """Yaw, pitch, roll (rad, in scipy's ``ZYX`` ranges) of the weighted ellipsoids with
    orientations ``ypr (N, 3)``: the chordal L2 mean of the rotations, each first turned by
    the symmetry of :data:`FLIPS` that brings it nearest the heaviest particle's."""
    w = np.exp(normalize(np.asarray(log_weights, float)).log_weights)
    return _nearest_rotation_ypr(flipped_rotation_sum(np.ascontiguousarray(ypr, float), w))


def _nearest_rotation_ypr(M: np.ndarray) -> np.ndarray:
    """Yaw, pitch, roll of the rotation nearest ``M`` (Frobenius): ``U Vt`` of its SVD, with
    the last singular direction turned where that is a reflection."""
    U, _, Vt = np.linalg.svd(M)
    R_mean = U @ Vt
    (a, b, c), (d_, e, f), (g, h, i) = R_mean.tolist()
    if a * (e * i - f * h) - b * (d_ * i - f * g) + c * (d_ * h - e * g) < 0.0:  # reflection
        R_mean = U @ (Vt * np.array([1.0, 1.0, -1.0])[:, None])   # U diag(1, 1, -1) Vt
    return ypr_from_matrix(R_mean)


def mean_orientation_numpy(ypr: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    """:func:`mean_orientation` in array operations (its reference in tests)."""
    w = np.exp(normalize(np.asarray(log_weights, float)).log_weights)
    R = ypr_matrix(*np.asarray(ypr, float).T)                              # (N, 3, 3)
    R0 = R[int(np.argmax(w))]
    # a half turn F = diag(d) flips the signs of R's columns: trace(R0^T R F) = sum_j d_j c_j
    # with c_j the dot product of the two matrices' j-th columns
    signs = np.diagonal(FLIPS, axis1=1, axis2=2)                           # (4, 3)
    c = np.einsum("ij,nij->nj", R0, R)                                     # (N, 3)
    d = signs[np.argmax(c @ signs.T, axis=1)]                              # (N, 3)
    return _nearest_rotation_ypr(np.einsum("nij,nj->ij", R, w[:, None] * d))
