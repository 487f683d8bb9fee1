"""Growing, shrinking and re-parameterising an EKF state made of blocks (pure functions).

The SLAM state is the interface followed by one block per map feature. New features append
rows and columns; deleted ones drop theirs; an inverse-depth block that becomes XYZ (6 numbers
to 3) goes through its conversion Jacobian. Each returns a new ``(x, P)``; costs are
``O(n^2)``, never a dense ``n x n`` Jacobian product.
"""

from __future__ import annotations

import numpy as np


def append(x: np.ndarray, P: np.ndarray, y: np.ndarray, cross: np.ndarray,
           Pyy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``x`` with ``y`` appended; ``P`` with the new rows ``cross (m, n)`` (their covariance
    with the old state) and their own block ``Pyy (m, m)``."""
    n, m = len(x), len(y)
    P_new = np.empty((n + m, n + m))
    P_new[:n, :n] = P
    P_new[n:, :n] = cross
    P_new[:n, n:] = cross.T
    P_new[n:, n:] = Pyy
    return np.concatenate([x, y]), P_new


def select(x: np.ndarray, P: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The state restricted to ``cols`` (in that order)."""
    return x[cols], P[np.ix_(cols, cols)]


def convert(x: np.ndarray, P: np.ndarray, old: np.ndarray, new: np.ndarray,
            src: np.ndarray, dst: np.ndarray, values: np.ndarray, J: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """``x' = T(x)``, ``P' = J_T P J_T^T`` for a ``T`` that copies the columns ``old`` to
    ``new`` and maps each block ``src[i]`` (``(c, d)`` columns) to ``dst[i]`` (``(c, e)``)
    with value ``values[i] (e,)`` and Jacobian ``J[i] (e, d)``. The block-diagonal ``J_T`` is
    applied to the rows, then to the columns."""
    r = len(new) + dst.size
    x_new = np.empty(r)
    x_new[new], x_new[dst] = x[old], values
    rows = np.empty((r, len(x)))
    rows[new] = P[old]
    rows[dst] = np.einsum("kij,kjn->kin", J, P[src])
    P_new = np.empty((r, r))
    P_new[:, new] = rows[:, old]
    P_new[:, dst] = np.einsum("nkj,kij->nki", rows[:, src], J)
    return x_new, P_new
