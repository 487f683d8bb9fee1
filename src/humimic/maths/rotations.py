"""The smallest rotation taking one direction onto another, vectorised over rows."""

from __future__ import annotations

import numpy as np


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` the smallest rotations taking directions ``a (N, 3)`` to ``b (N, 3)``
    (Rodrigues; identity where they coincide, a half turn about a perpendicular where opposite)."""
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=1)
    s2 = np.sum(v * v, axis=1)
    K = np.zeros((len(a), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(s2 > 1e-24, (1.0 - c) / s2, 0.5)
    R = np.eye(3) + K + f[:, None, None] * (K @ K)
    opposite = (s2 <= 1e-24) & (c < 0)
    if opposite.any():                       # a half turn about any axis perpendicular to a
        p = np.cross(a[opposite], np.eye(3)[np.argmin(np.abs(a[opposite]), axis=1)])
        p /= np.linalg.norm(p, axis=1, keepdims=True)
        R[opposite] = 2.0 * p[:, :, None] * p[:, None, :] - np.eye(3)
    return R
