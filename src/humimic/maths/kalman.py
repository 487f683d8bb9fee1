"""The (extended) Kalman update shared by every EKF: Joseph form, with the innovation's
covariance returned for gating and consistency checks (NIS)."""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve


def kalman_update(x: np.ndarray, P: np.ndarray, innovation: np.ndarray, H: np.ndarray,
                  R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``x + K y``, the Joseph-form ``(I - KH) P (I - KH)^T + K R K^T`` and ``S = H P H^T + R``
    for innovation ``y = z - h(x)`` (as filterpy's ``ExtendedKalmanFilter.update``)."""
    PHt = P @ H.T
    S = H @ PHt + R
    K = cho_solve(cho_factor(S), PHt.T).T
    IKH = np.eye(len(x)) - K @ H
    Pn = IKH @ P @ IKH.T + K @ R @ K.T
    return x + K @ innovation, 0.5 * (Pn + Pn.T), S


def nis(innovation: np.ndarray, S: np.ndarray) -> float:
    """Normalised innovation squared ``y^T S^-1 y`` (chi-square with ``len(y)`` dof)."""
    return float(innovation @ np.linalg.solve(S, innovation))
