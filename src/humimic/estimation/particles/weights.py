"""Log-weights: normalisation, evidence, effective sample size and weighted moments.

Weights are kept as natural logs throughout (a likelihood of 1e-400 is a log-weight of -921,
not a zero). A particle of zero weight has log-weight ``-inf``. When *every* particle has
zero weight the set carries no information: :func:`normalize` then reports it (``ok=False``,
evidence ``-inf``) and returns uniform weights instead of dividing by zero -- no NaN ever
leaves this module.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


def logsumexp(a: np.ndarray) -> float:
    """``log(sum(exp(a)))`` of a 1-D array, ``-inf`` when every entry is ``-inf``."""
    a = np.asarray(a, dtype=np.float64)
    m = a.max(initial=-np.inf)
    if not np.isfinite(m):
        return float(m) if m == np.inf else -np.inf
    return float(m + np.log(np.exp(a - m).sum()))


class Normalized(NamedTuple):
    log_weights: np.ndarray
    """Normalised log-weights (``logsumexp == 0``); uniform when ``ok`` is False."""
    log_total: float
    """``log sum exp`` of the input (``-inf`` when every weight was zero)."""
    ok: bool
    """False when every weight was zero (or the input held NaN): the weights carry nothing."""


def uniform_log_weights(n: int) -> np.ndarray:
    return np.full(n, -np.log(n))


def normalize(log_weights: np.ndarray) -> Normalized:
    """Normalise log-weights; report (not raise, not NaN) when all are zero or any is NaN."""
    lw = np.asarray(log_weights, dtype=np.float64)
    if np.isnan(lw).any():
        return Normalized(uniform_log_weights(len(lw)), -np.inf, False)
    total = logsumexp(lw)
    if not np.isfinite(total):
        return Normalized(uniform_log_weights(len(lw)), total, False)
    return Normalized(lw - total, total, True)


def weights(log_weights: np.ndarray) -> np.ndarray:
    """Linear normalised weights (sum 1) from log-weights (normalised or not)."""
    n = normalize(log_weights)
    return np.exp(n.log_weights)


def weights_columns(log_weights: np.ndarray) -> np.ndarray:
    """:func:`weights` of each column of ``log_weights (N, G)``, ``(N, G)``, in one pass (the
    same operations on each column, the sums over contiguous rows: equal to the per-column
    calls bit for bit); a column holding NaN, or with no finite total, uniform as there."""
    T = np.ascontiguousarray(np.asarray(log_weights, np.float64).T)       # (G, N)
    m = T.max(axis=1, keepdims=True, initial=-np.inf)
    with np.errstate(invalid="ignore", over="ignore"):
        total = m + np.log(np.exp(T - m).sum(axis=1, keepdims=True))
        out = np.exp(T - total)
    bad = ~np.isfinite(total[:, 0]) | np.isnan(T).any(axis=1)
    if bad.any():
        out[bad] = np.exp(uniform_log_weights(T.shape[1]))
    return np.ascontiguousarray(out.T)


def effective_sample_size(log_weights: np.ndarray) -> float:
    """Kish's effective sample size ``1 / sum(w_i^2)`` of the normalised weights (1..N)."""
    return ess_of_weights(weights(log_weights))


def ess_of_weights(w: np.ndarray) -> float:
    """:func:`effective_sample_size` of linear weights already from :func:`weights`."""
    return float(1.0 / np.dot(w, w))


def weighted_mean(particles: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    """The weighted mean of particles ``(N, d)`` (the MMSE estimate, Table 1 step 7)."""
    return mean_of_weights(particles, weights(log_weights))


def mean_of_weights(particles: np.ndarray, w: np.ndarray) -> np.ndarray:
    """:func:`weighted_mean` with linear weights already from :func:`weights`."""
    return w @ np.asarray(particles, dtype=np.float64)


def weighted_cov(particles: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    """The weighted covariance ``(d, d)`` of particles ``(N, d)`` about their weighted mean."""
    w = weights(log_weights)
    x = np.asarray(particles, dtype=np.float64)
    dx = x - w @ x
    return (dx * w[:, None]).T @ dx
