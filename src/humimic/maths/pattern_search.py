"""Derivative-free local maximisation by a batched pattern (compass) search.

Each poll evaluates ``x +- step_k d_k`` for every direction ``d_k`` in one batch (the objective
is vectorised over candidates), moves to the best candidate if it beats ``f(x)``, and halves
the steps otherwise (Kolda, Lewis & Torczon, "Optimization by direct search", SIAM Review
2003, the compass search of sec. 1.1 with a batched, best-improvement poll). It never returns
a point scoring below its start.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SearchResult:
    x: np.ndarray
    """(d,) the best point found."""
    value: float
    """Its objective."""
    start_value: float
    """The objective at the start."""
    evaluations: int
    """Objective evaluations (points), the start included."""


def pattern_search(f: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
                   directions: np.ndarray, steps: np.ndarray, polls: int,
                   shrink: float = 0.5, project: Callable[[np.ndarray], np.ndarray] | None = None
                   ) -> SearchResult:
    """Maximise ``f`` (``(M, d) -> (M,)``) from ``x0 (d,)`` over ``polls`` batched polls along
    ``directions (K, d)`` with initial step lengths ``steps (K,)`` (each direction its own; a
    failed poll multiplies them all by ``shrink``). ``project`` (optional) maps candidates
    into the feasible set (e.g. joint limits) before they are evaluated. Non-finite values
    never win."""
    x = np.asarray(x0, float).copy()
    dirs = np.asarray(directions, float)
    step = np.asarray(steps, float).copy()
    fx = float(np.asarray(f(x[None]), float)[0])
    start, n = fx, 1
    if not np.isfinite(fx):     # a non-finite start: any finite candidate beats it
        fx = -np.inf
    for _ in range(polls):
        delta = np.concatenate([dirs * step[:, None], -dirs * step[:, None]])
        cand = x[None] + delta
        if project is not None:
            cand = project(cand)
        v = np.asarray(f(cand), float)
        n += len(cand)
        v = np.where(np.isfinite(v), v, -np.inf)
        k = int(np.argmax(v))
        if v[k] > fx:
            x, fx = cand[k].copy(), float(v[k])
        else:
            step *= shrink
    return SearchResult(x, fx, start, n)
