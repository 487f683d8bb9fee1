"""Resampling: draw N ancestor indices with probabilities equal to the weights (Table 1, step 8).

Each scheme has a pure form taking the uniforms it consumes (so it can be checked against
filterpy's on the same numbers) and is reached through :func:`resample_indices`, which draws
those uniforms from a ``numpy.random.Generator``. All are unbiased: particle ``i`` is copied
``N w_i`` times on average. Variance of the copy counts: multinomial > residual > stratified
>= systematic (Douc, Cappe & Moulines 2005); systematic is the default, as in most trackers.

An index ``j`` is chosen for a position ``p`` in [0, 1) when ``c_{j-1} <= p < c_j`` with ``c``
the cumulative weights normalised by their last value (so rounding never runs off the end and
a zero-weight particle is never chosen).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from humimic.estimation.particles.weights import weights

Method = Literal["systematic", "stratified", "residual", "multinomial"]
METHODS: tuple[str, ...] = ("systematic", "stratified", "residual", "multinomial")


def _cumulative(w: np.ndarray) -> np.ndarray:
    c = np.cumsum(np.asarray(w, dtype=np.float64))
    return c / c[-1]


def _select(w: np.ndarray, positions: np.ndarray) -> np.ndarray:
    c = _cumulative(w)
    return np.minimum(np.searchsorted(c, positions, side="right"), len(c) - 1)


def systematic_indices(w: np.ndarray, u: float, n: int | None = None) -> np.ndarray:
    """Systematic resampling: ``n`` (default N) positions ``(u + i) / n`` for one uniform
    ``u`` in [0, 1)."""
    n = len(w) if n is None else n
    return _select(w, (u + np.arange(n)) / n)


def stratified_indices(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Stratified resampling: positions ``(u_i + i) / n`` for ``n = len(u)`` uniforms."""
    u = np.asarray(u)
    return _select(w, (u + np.arange(len(u))) / len(u))


def multinomial_indices(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Multinomial resampling: one independent position per uniform in ``u``."""
    return _select(w, np.asarray(u))


def residual_counts(w: np.ndarray, n: int | None = None) -> np.ndarray:
    """The deterministic part of residual resampling: ``floor(n w_i)`` copies of particle i."""
    n = len(w) if n is None else n
    return np.floor(n * np.asarray(w, dtype=np.float64)).astype(np.int64)


def residual_indices(w: np.ndarray, u: np.ndarray, n: int | None = None) -> np.ndarray:
    """Residual resampling (Liu & Chen 1998): ``floor(n w_i)`` copies of each particle, the
    remaining ``R = n - sum floor(n w_i)`` drawn multinomially from the residuals
    ``n w_i - floor(n w_i)``; ``u`` holds (at least) R uniforms.

    (filterpy 2.0.0's ``residual_resample`` subtracts the counts from ``w`` instead of from
    ``n w``, which makes the residuals negative: it is not used as a reference here.)"""
    w = np.asarray(w, dtype=np.float64)
    n = len(w) if n is None else n
    counts = residual_counts(w, n)
    fixed = np.repeat(np.arange(len(w)), counts)
    rest = n - len(fixed)
    if rest == 0:
        return fixed
    return np.concatenate([fixed, _select(n * w - counts, np.asarray(u)[:rest])])


def resample_indices(log_weights: np.ndarray, rng: np.random.Generator,
                     method: Method = "systematic", n: int | None = None) -> np.ndarray:
    """``n`` (default N) ancestor indices drawn with probabilities given by (unnormalised)
    ``log_weights``."""
    return indices_from_weights(weights(log_weights), rng, method, n)


def indices_from_weights(w: np.ndarray, rng: np.random.Generator,
                         method: Method = "systematic", n: int | None = None) -> np.ndarray:
    """:func:`resample_indices` of linear weights already from
    :func:`~humimic.estimation.particles.weights.weights` (drawing the same uniforms)."""
    n = len(w) if n is None else n
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if method == "systematic":
        return systematic_indices(w, rng.random(), n)
    if method == "stratified":
        return stratified_indices(w, rng.random(n))
    if method == "multinomial":
        return multinomial_indices(w, rng.random(n))
    if method == "residual":
        return residual_indices(w, rng.random(n - int(residual_counts(w, n).sum())), n)
    raise ValueError(f"unknown resampling method {method!r}; allowed: {', '.join(METHODS)}")
