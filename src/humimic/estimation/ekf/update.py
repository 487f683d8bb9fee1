"""EKF steps on a large state whose models touch few columns (pure, in place, allocation-light).

The SLAM state is the 19-number interface followed by the map. A feature reads the camera pose
``(p, q)`` and its own 3 or 6 columns: the cost of its update is the unavoidable
``P -= K (P H^T)^T`` (``n^2 m``) plus ``O(n m)`` for the rest, never a product with a dense
``n x n`` Jacobian. (The predictions and the inertial updates touch the interface alone; the
filter handles them on its 19x19 block, :class:`~humimic.estimation.ekf.slam.SlamFilter`.)
"""

from __future__ import annotations

import numpy as np


def transform_rows(P: np.ndarray, rows: slice, J: np.ndarray) -> None:
    """``P = T P T^T`` in place for ``T`` the identity except ``J`` on ``rows`` (a slice),
    ``P`` symmetric (e.g. renormalising the quaternion)."""
    P[rows, :] = J @ P[rows, :]
    P[rows, rows] = P[rows, rows] @ J.T
    P[:rows.start, rows] = P[rows, :rows.start].T
    P[rows.stop:, rows] = P[rows, rows.stop:].T


def gain_update(x: np.ndarray, P: np.ndarray, PHt: np.ndarray, S: np.ndarray,
                innovation: np.ndarray) -> None:
    """``K = P H^T S^-1``, ``x += K ν``, ``P -= K (P H^T)^T`` (= ``K S K^T``), in place.

    ``PHt (n, m)`` and ``S (m, m)`` (innovation covariance, ``R`` included) are from
    :func:`dense_PHt` or :func:`features_PHt`. Raises ``LinAlgError`` if ``S`` has a
    non-positive diagonal or is singular (the caller skips the update).
    """
    if not np.all(np.diagonal(S) > 0.0):  # a broken covariance: refuse rather than diverge
        raise np.linalg.LinAlgError("innovation covariance is not positive definite")
    Kt = np.linalg.solve(S, PHt.T)  # (m, n) = S^-1 (P H^T)^T = K^T
    x += innovation @ Kt
    P -= Kt.T @ PHt.T


def dense_PHt(P: np.ndarray, cols: np.ndarray, H: np.ndarray) -> np.ndarray:
    """``P H^T`` for a Jacobian that is ``H (m, c)`` on the columns ``cols`` and zero elsewhere."""
    return P[:, cols] @ H.T


def dense_S(PHt: np.ndarray, cols: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``H P H^T + R`` from ``P H^T`` (same sparse ``H`` as :func:`dense_PHt`)."""
    return H @ PHt[cols] + R


def features_PHt(P: np.ndarray, pose_cols: np.ndarray, H_pose: np.ndarray,
                 groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> np.ndarray:
    """``P H^T`` ``(n, 2k)`` for ``k`` image measurements, two rows each.

    Measurement ``i`` reads the shared pose columns (``H_pose[2i:2i+2]``, ``(2k, c)`` in all)
    and its own feature's ``d`` columns ``offsets[i] + range(d)``. ``groups`` lists, per
    feature size, ``(rows, offsets, H_f)``: which measurements (indices into the ``k``), their
    state offsets and Jacobians ``(len(rows), 2, d)``.
    """
    n = P.shape[0]
    PHt = P[:, pose_cols] @ H_pose.T
    view = PHt.reshape(n, -1, 2)
    for rows, offsets, H_f in groups:
        idx = offsets[:, None] + np.arange(H_f.shape[2])
        view[:, rows] += np.einsum("nkd,kid->nki", P[:, idx], H_f)
    return PHt


def features_S(PHt: np.ndarray, pose_cols: np.ndarray, H_pose: np.ndarray,
               groups: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
               sigma_px: float) -> np.ndarray:
    """``H P H^T + σ^2 I`` ``(2k, 2k)`` from :func:`features_PHt`'s ``P H^T``."""
    S = H_pose @ PHt[pose_cols]
    view = S.reshape(-1, 2, S.shape[1])
    for rows, offsets, H_f in groups:
        idx = offsets[:, None] + np.arange(H_f.shape[2])
        view[rows] += np.einsum("kid,kdm->kim", H_f, PHt[idx])
    S[np.diag_indices_from(S)] += sigma_px**2
    return S


def symmetrize(P: np.ndarray) -> None:
    """``P = (P + P^T)/2`` in place (rounding makes repeated updates drift apart)."""
    P += P.T
    P *= 0.5
