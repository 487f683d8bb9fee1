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
    C = np.empty((len(t), 4, 4))
    C[:, 0:2, 0:2] = C[:, 0:2, 2:4] = C[:, 2:4, 0:2] = Cl
    C[:, 2:4, 2:4] = Cl + match_std**2 * t[:, :, None] * t[:, None, :]
    return C
