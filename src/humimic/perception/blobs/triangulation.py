"""Triangulation of a stereo correspondence and its Jacobian (for covariance propagation).

Homogeneous linear triangulation (DLT, as ``cv2.triangulatePoints``) of undistorted
normalised points, the analytic Jacobian of the result w.r.t. the four image coordinates
(first-order perturbation of the DLT null vector), and the radial (un)distortion helpers that
chain raw pixels to normalised coordinates. Used by :mod:`humimic.perception.blobs.stereo`
(Ude eq. 10 and the covariance propagation of Table 2).
"""

from __future__ import annotations

import numpy as np

from humimic.sensors.camera_model import Intrinsics


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


def undistort_point(intr: Intrinsics, u: float, v: float, iterations: int = 8
                    ) -> tuple[float, float]:
    """One pixel to undistorted normalised coordinates (scalar fixed point, as Intrinsics)."""
    xd, yd = (u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy
    x, y = xd, yd
    if intr.k1 != 0.0 or intr.k2 != 0.0:
        for _ in range(iterations):
            r2 = x * x + y * y
            s = 1.0 + intr.k1 * r2 + intr.k2 * r2 * r2
            x, y = xd / s, yd / s
    return x, y


def undistort_jacobian(intr: Intrinsics, x: float, y: float) -> list[list[float]]:
    """d(undistorted normalised point)/d(pixel) (2x2) at the undistorted point ``(x, y)``."""
    r2 = x * x + y * y
    s = 1.0 + intr.k1 * r2 + intr.k2 * r2 * r2
    ds = 2.0 * (intr.k1 + 2.0 * intr.k2 * r2)
    a, b, d = s + ds * x * x, ds * x * y, s + ds * y * y  # d(distorted)/d(undistorted)
    det = a * d - b * b
    return [[d / (det * intr.fx), -b / (det * intr.fy)],
            [-b / (det * intr.fx), a / (det * intr.fy)]]


def distort_to_pixels(intr: Intrinsics, x: np.ndarray, y: np.ndarray):
    """Undistorted normalised coordinates to raw (distorted) pixels (arrays)."""
    if intr.k1 == 0.0 and intr.k2 == 0.0:  # s == 1 exactly (finite inputs)
        return intr.fx * x + intr.cx, intr.fy * y + intr.cy
    r2 = x * x + y * y
    s = 1.0 + r2 * (intr.k1 + intr.k2 * r2)
    return intr.fx * x * s + intr.cx, intr.fy * y * s + intr.cy


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
