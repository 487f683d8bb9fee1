"""Normalised estimation error squared (NEES) and its chi-square consistency bounds.

For a consistent Kalman filter, ``e^T P^-1 e`` of the state error ``e = x_hat - x_true`` is
chi-square distributed with ``n`` degrees of freedom (Bar-Shalom, Li & Kirubarajan,
*Estimation with Applications to Tracking and Navigation*, Sec. 5.4.2). Over a window of ``N``
consecutive epochs of one run, the mean NEES times ``N`` is approximately chi-square with
``N n`` degrees of freedom (errors of a single run are correlated in time, so this is a
guide, not a test); its two-sided 95 % interval shows at a glance whether the filter's
covariance is too small (NEES above) or too large (below) for its actual errors.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2


def nees(err: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``e_k^T P_k^-1 e_k`` for errors ``(N, n)`` and covariances ``(N, n, n)``; NaN where
    ``P`` is singular."""
    err = np.asarray(err, float)
    out = np.full(len(err), np.nan)
    for k in range(len(err)):
        try:
            out[k] = err[k] @ np.linalg.solve(P[k], err[k])
        except np.linalg.LinAlgError:
            pass
    return out


def chi2_bounds(dof: int, n_avg: int = 1, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` interval of the mean of ``n_avg`` chi-square(``dof``) variables."""
    a = (1.0 - level) / 2.0
    k = dof * n_avg
    return float(chi2.ppf(a, k) / n_avg), float(chi2.ppf(1.0 - a, k) / n_avg)


def moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Trailing mean over ``n`` samples (shorter at the start), ignoring NaN."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    c = np.concatenate([[0.0], np.cumsum(np.where(ok, x, 0.0))])
    m = np.concatenate([[0], np.cumsum(ok)])
    idx = np.arange(1, len(x) + 1)
    lo = np.maximum(idx - n, 0)
    count = m[idx] - m[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, (c[idx] - c[lo]) / count, np.nan)
