"""Triangulation of a stereo correspondence and its Jacobian (for covariance propagation).

Homogeneous linear triangulation (DLT, as ``cv2.triangulatePoints``) of undistorted
normalised points, the analytic Jacobian of the result w.r.t. the four image coordinates
(first-order perturbation of the DLT null vector), and the pixel covariances of a stereo
correspondence. Raw pixels and normalised coordinates are converted by
:class:`humimic.sensors.camera_model.Intrinsics` (the one camera model). Used by
:mod:`humimic.perception.blobs.stereo` (Ude eq. 10 and the covariance propagation of Table 2).
"""

from __future__ import annotations

import numpy as np


def triangulate_dlt(P1: np.ndarray, P2: np.ndarray, x1: np.ndarray, x2: np.ndarray):
    """Homogeneous DLT of N points ``x1, x2 (N, 2)`` from two 3x4 cameras.

    Returns the unit null vectors ``X_h (N, 4)`` and the SVD ``(A, s, Vt)`` of the systems.
    """
    A = np.empty((len(x1), 4, 4))
    A[:, 0:2] = x1[:, :, None] * P1[2] - P1[0:2]
    A[:, 2:4] = x2[:, :, None] * P2[2] - P2[0:2]
    _, s, Vt = np.linalg.svd(A)
    return Vt[:, 3], (A, s, Vt)


def dlt_jacobian(P1: np.ndarray, P2: np.ndarray, X_h: np.ndarray, svd) -> np.ndarray:
    """d(Euclidean point)/d(x1, y1, x2, y2) ``(N, 3, 4)`` by perturbing the DLT null vector.

    ``X_h`` is the eigenvector of ``M = A^T A`` of smallest eigenvalue ``s4^2``; to first order
    ``dX_h = -(M - s4^2 I)^+ dM X_h``, ``dM = dA^T A + A^T dA``, and ``dA`` for coordinate ``i``
    has row ``i`` = the third row of its camera's ``P``.
    """
    A, s, Vt = svd
    V3 = Vt[:, :3]  # (N, 3, 4)
    pinv = np.swapaxes(V3, 1, 2) / (s[:, :3] ** 2 - s[:, 3:] ** 2)[:, None, :] @ V3
    rows = np.stack([P1[2], P1[2], P2[2], P2[2]])  # (4, 4)
    AX = np.einsum("nij,nj->ni", A, X_h)
    dMX = rows * AX[:, :, None] + A * (X_h @ rows.T)[:, :, None]  # [n, i]: dM_i X_h
    dX = -dMX @ pinv  # (N, 4 coords, 4)
    Xe = X_h[:, :3] / X_h[:, 3:]
    J = (dX[:, :, :3] - dX[:, :, 3:] * Xe[:, None, :]) / X_h[:, 3, None, None]
    return np.swapaxes(J, 1, 2)


def joint_covariance(n: int, cov_left, cov_right, cov_joint) -> np.ndarray:
    """(n, 4, 4) pixel covariance of (u_l, v_l, u_r, v_r): ``cov_joint`` or block-diagonal."""
    C = np.zeros((n, 4, 4))
    if cov_joint is not None:
        C[:] = cov_joint
        return C
    if cov_left is not None:
        C[:, 0:2, 0:2] = cov_left
    if cov_right is not None:
        C[:, 2:4, 2:4] = cov_right
    return C


def following_covariance(cov_left: np.ndarray, match_std: float, t_right: np.ndarray
                         ) -> np.ndarray:
    """Joint pixel covariance ``(N, 4, 4)`` of a correspondence whose right point *follows* the
    left one: ``[[C_l, C_l], [C_l, C_l + s^2 t t^T]]``.

    The template is cut around the left blob centre, so an error ``e`` of that centre moves
    the right match by about ``e`` too (a locally fronto-parallel surface), and the match adds
    its own error of standard deviation ``match_std`` (px) along the epipolar line (raw-pixel
    direction ``t_right (N, 2)``, normalised here). Centre errors then move the point sideways
    but hardly in depth; depth noise comes from the match alone. (Propagating independent left
    and right covariances, as Ude & Atkeson's Table 2 does, overstates depth noise when the
    centre's error dominates the match's.)
    """
    t = np.asarray(t_right, float).reshape(-1, 2)
    t = t / np.linalg.norm(t, axis=1, keepdims=True)
    Cl = np.broadcast_to(np.asarray(cov_left, float), (len(t), 2, 2))
    s2 = np.broadcast_to(np.square(np.asarray(match_std, float)), (len(t),))
    C = np.empty((len(t), 4, 4))
    C[:, 0:2, 0:2] = C[:, 0:2, 2:4] = C[:, 2:4, 0:2] = Cl
    C[:, 2:4, 2:4] = Cl + s2[:, None, None] * t[:, :, None] * t[:, None, :]
    return C


#: Blobs narrower than this (the mean of the two standard deviations, px) grow the noises no
#: further (:func:`small_blob_scale`). Measured (mimic_tracked_wave seed 7, waving hand): the
#: disparity error was 0.078-0.081 px at sigma 2.55 px (1.63 m) and 0.080-0.085 px at 1.87 px
#: (2.23 m): it stops growing once the blob is ~5 px across (the template's 1 px sample spacing
#: then spans it in a few samples). Without the floor the hand's R at 2.4 m was 1.26x its
#: error and 19 % of the filter's NEES fell below the 95 % band.
SMALL_BLOB_FLOOR_PX = 2.5
#: The blob width (px) the shipped pixel noises were calibrated at
#: (``perception.noise_ref_sigma_px``).
NOISE_REF_SIGMA_PX = 5.0


def small_blob_scale(blob_cov: np.ndarray, sigma_ref_px: float | None,
                     sigma_floor_px: float = SMALL_BLOB_FLOOR_PX) -> np.ndarray:
    """Factor ``max(1, sigma_ref_px / max(sigma_blob, sigma_floor_px))`` ``(N,)`` by which the
    calibrated pixel noises (``pixel_std``, ``match_std``) grow for blobs smaller than the ones
    they were calibrated on; ``sigma_blob`` is the mean of each blob's two standard deviations
    (``blob_cov (N, 2, 2)``, px^2). None: ones.

    Our extension of Ude & Atkeson's Table 2 (one pixel covariance for every blob). Their
    3-D covariance ``J C J^T`` (first-order propagation, Hartley & Zisserman 2nd ed., result
    5.6) already grows as depth^2 / (focal length * baseline) along the line of sight for a
    fixed pixel noise; but the noise in pixels is not fixed: the blob's outline, which the
    centre and the stereo template rest on, is sampled by fewer pixels the smaller the blob.
    Measured (mimic_tracked_wave seed 7, wide 320x240, disparity error std in px against the
    truth): head sigma 5.5 px (1.14 m) 0.038, 3.6 px (1.74 m) 0.059; waving hand 4.0 px (1.05 m)
    0.047, 2.55 px (1.63 m) 0.078 -- about 0.2 px^2 / sigma_blob, for light and dark skin alike.
    Blobs at least ``sigma_ref_px`` wide keep the calibrated noise (no filter grows
    under-confident near the eyes).
    """
    c = np.asarray(blob_cov, float).reshape(-1, 2, 2)
    if sigma_ref_px is None:
        return np.ones(len(c))
    half_tr = 0.5 * (c[:, 0, 0] + c[:, 1, 1])
    root = np.sqrt(np.maximum(0.25 * (c[:, 0, 0] - c[:, 1, 1]) ** 2 + c[:, 0, 1] ** 2, 0.0))
    sigma = 0.5 * (np.sqrt(np.maximum(half_tr + root, 0.0))
                   + np.sqrt(np.maximum(half_tr - root, 0.0)))
    return np.maximum(1.0, sigma_ref_px / np.maximum(sigma, sigma_floor_px))


def match_noise_px(match_std, scale, floor_px: float | None = None) -> np.ndarray:
    """Standard deviation (px) of the stereo match along the epipolar line: the calibrated
    ``match_std`` grown by ``scale`` (:func:`small_blob_scale`) and, with ``floor_px``, a
    floor added in quadrature, ``sqrt((match_std scale)^2 + floor_px^2)`` (``(N,)``).

    The floor is the match error of a blob's outline cut at whole pixels: without
    multisampling a render's edges are hard steps and the colour mask keeps them hard, so the
    outline each eye sees is its own rounding of the true one and the match between them is
    off by a fraction of a pixel that no sub-pixel search recovers. For a still target the
    error is the same in every frame (a bias the filter cannot average, and the calibration,
    which removes each target's mean error, does not see); a moving one draws a new error
    each frame. Measured with this matcher on flat hard-edged discs (sigma 2.3-4.6 px, random
    sub-pixel positions, colour-masked): 0.069-0.104 px RMS per size, 0.084 pooled; the still
    head of ``mimic_tracked_wave`` (1.2-2.4 m): 0.10 px RMS of its per-run mean
    (``docs/ude_perception_notes.md``, "Hard-edged outlines").
    """
    base = np.asarray(match_std, float) * np.asarray(scale, float)
    if floor_px is None:
        return base
    return np.sqrt(np.square(base) + float(floor_px) ** 2)
