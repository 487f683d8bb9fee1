"""Error statistics with one convention for empty data.

Errors are row vectors ``(N, d)`` (or ``(N,)`` scalars). Rows containing a NaN are skipped
(a target not measured in that frame); a statistic over no rows is NaN. Convert to JSON's
``null`` at the metrics boundary with :func:`finite_or_none`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2


def _rows(err) -> np.ndarray:
    """``err`` as rows ``(N, d)``: scalars ``(N,)`` as ``(N, 1)``, ``(N, ...)`` flattened per
    row -- by the row's shape, not ``reshape(N, -1)``, which cannot size an empty array (a
    tracker that never tracked a visible target: ``scale_rmse_px`` over no frames had raised
    and lost the run's metrics)."""
    e = np.asarray(err, dtype=float)
    if e.ndim != 2:
        e = e.reshape(len(e), int(np.prod(e.shape[1:], dtype=int)))
    return e[np.all(np.isfinite(e), axis=1)]


def rmse(err) -> float:
    """Root mean squared norm of the finite rows of ``err``; NaN if there are none."""
    return rms_of(*sum_squares(err))


def sum_squares(err) -> tuple[float, int]:
    """``(sum of squared norms, count)`` of the finite rows of ``err``: :func:`rmse`'s partial
    sums, which add over blocks of rows (a long run's RMS without its whole columns; equal to
    the whole array's to rounding, as the sums are grouped differently)."""
    e = _rows(err)
    return float(np.sum(np.sum(e * e, axis=1))), len(e)


def rms_of(total: float, count: int) -> float:
    """``sqrt(total / count)`` from :func:`sum_squares`' (added) sums; NaN if ``count`` is 0."""
    return math.sqrt(total / count) if count else math.nan


NEES_BLOCK = 4096
"""Samples per block in :func:`nees` (its temporaries stay small in a long run's scores)."""


def nees(err, P) -> np.ndarray:
    """Normalised estimation error squared ``e_k^T P_k^-1 e_k`` per sample.

    ``err (N, n)``, ``P (N, n, n)`` (or one ``(n, n)`` for all); NaN where ``P`` is singular
    or ``e`` is not finite. For a consistent filter each value is chi-square with ``n``
    degrees of freedom (Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2). Computed
    :data:`NEES_BLOCK` samples at a time.
    """
    e = np.atleast_2d(np.asarray(err, dtype=float))
    P = np.broadcast_to(np.asarray(P, dtype=float), (len(e),) + (e.shape[1],) * 2)
    out = np.full(len(e), np.nan)
    for s in range(0, len(e), NEES_BLOCK):
        out[s:s + NEES_BLOCK] = _nees_block(e[s:s + NEES_BLOCK], P[s:s + NEES_BLOCK])
    return out


def _nees_block(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    out = np.full(len(e), np.nan)
    ok = np.all(np.isfinite(e), axis=1) & np.all(np.isfinite(P), axis=(1, 2))
    if not ok.any():
        return out
    idx = np.flatnonzero(ok)
    try:
        sol = np.linalg.solve(P[idx], e[idx][..., None])[..., 0]
        out[idx] = np.einsum("ni,ni->n", e[idx], sol)
    except np.linalg.LinAlgError:  # some P singular: fall back per sample
        for k in idx:
            try:
                out[k] = e[k] @ np.linalg.solve(P[k], e[k])
            except np.linalg.LinAlgError:
                pass
    return out


def chi2_band(dof: int, n_avg: int = 1, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` interval of the mean of ``n_avg`` independent chi-square(``dof``)
    values (the band a consistent filter's NEES, averaged over ``n_avg`` samples, falls in)."""
    a = (1.0 - level) / 2.0
    k = dof * n_avg
    return float(chi2.ppf(a, k) / n_avg), float(chi2.ppf(1.0 - a, k) / n_avg)


def fraction_in_band(values, dof: int, level: float = 0.95) -> float:
    """Fraction of the finite per-sample NEES ``values`` inside the single-sample band."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return math.nan
    lo, hi = chi2_band(dof, 1, level)
    return float(np.mean((v >= lo) & (v <= hi)))


def fraction_above_band(values, dof: int, level: float = 0.95) -> float:
    """Fraction of the finite per-sample NEES ``values`` above the single-sample band's upper
    end (errors larger than their covariance allows; a consistent estimator: ``(1 - level)/2``):
    the one-sided half of the chi-square NEES test (Bar-Shalom, Li & Kirubarajan, *Estimation
    with Applications to Tracking and Navigation*, 2001, sec. 5.4.2)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return math.nan
    return float(np.mean(v > chi2_band(dof, 1, level)[1]))


def finite_or_none(x) -> float | None:
    """``float(x)`` if finite, else None (JSON's null in ``metrics.json``)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None
