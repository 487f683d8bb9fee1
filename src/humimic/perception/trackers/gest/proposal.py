"""GEST's dynamics and importance function as densities ICONDENSATION can weight exactly.

The hand may re-appear anywhere (it leaves the view, Fig. 11) with any orientation, but keeps
its size; so the reset of :class:`PoseReset` re-draws the centre and the orientation (the
first ``k = 6`` state dimensions) from the workspace box and walks the semi-axes on. The
importance function (:class:`CandidateProposal`) proposes the centre from the triangulated
skin blobs (eq. 17), the orientation from the particle set's predictive density or, for a
fraction ``fresh`` of its draws, uniformly (so orientations far from the current hypotheses
are explored), and the semi-axes from the predictive density. With the predictive density in
the denominator of ICONDENSATION's weights (:mod:`humimic.estimation.particles.filters`), a
particle proposed at a blob far from every hypothesis costs about ``eps U(p) / (alpha
pi(p))`` -- a ratio of 3-D densities -- instead of a ratio of 9-D ones, which with Table 5's
1e-4 m random walk on the semi-axes would leave it no weight at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from humimic.estimation.particles.densities import Mixture, RandomWalk, UniformBox
from humimic.estimation.particles.resampling import resample_indices
from humimic.maths.jit import njit

#: Centre, orientation and semi-axes in the 9-D state.
POS, ORI, AXES = slice(0, 3), slice(3, 6), slice(6, 9)
POSE = slice(0, 6)


#: Floor of the exponents in :func:`logsumexp`. ``exp`` below ~-745 underflows to 0 through
#: glibc's error path (errno), 3-4x the cost of a normal ``exp`` -- and most entries of a
#: particle filter's ``(N, N)`` density table are that far below the row's maximum; at -700
#: the term is 1e-304, which leaves a sum that is >= 1 unchanged.
EXP_FLOOR = -700.0
_LOG_2PI = math.log(2.0 * math.pi)


def logsumexp(a: np.ndarray, axis: int = -1) -> np.ndarray:
    """``log sum exp`` along ``axis`` (``-inf`` where every entry is): numpy only (scipy's
    costs ~0.2 ms a call, a tenth of a frame's budget)."""
    m = np.max(a, axis=axis, keepdims=True)
    if np.isfinite(m).all():            # the common case: every sum is >= 1, no log(0)
        z = np.maximum(a - m, EXP_FLOOR)
        return np.log(np.sum(np.exp(z, out=z), axis=axis)) + np.squeeze(m, axis)
    safe = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(a - safe), axis=axis)) + np.squeeze(safe, axis)
    return np.where(np.isfinite(np.squeeze(m, axis)), out, np.squeeze(m, axis))


@njit
def walk_tables(x, particles, log_weights, sigma, starts, floor):
    """``t_qij = log w_j - |(x_i - x_j)_{s_q:} / sigma_{s_q:}|^2 / 2`` for rows ``x (n, d)``
    and weighted ``particles (N, d)`` over the trailing dimensions from each of ``starts``
    (ascending), each row minus its maximum ``m_qi`` and floored at ``floor``
    (:data:`EXP_FLOOR`); rows whose maximum is not finite (NaN if the row holds one) are left
    zero. Returns ``(t (Q, n, N), m (Q, n))``: one compiled pass for all ``Q`` tables (the
    squared distances summed from the last dimension backwards), no temporaries; the
    exponentials are left to numpy, whose vectorised ``exp`` a compiled loop does not match."""
    n, d = x.shape
    N, Q = particles.shape[0], len(starts)
    inv = 1.0 / sigma
    ps = np.empty((d, N))                   # scaled, one row per dimension: loops over j
    for j in range(N):                      # vectorise
        for k in range(d):
            ps[k, j] = particles[j, k] * inv[k]
    t = np.empty((Q, n, N))
    m = np.empty((Q, n))
    acc = np.empty(N)
    clean = not (np.isnan(x).any() or np.isnan(particles).any() or np.isnan(log_weights).any())
    for i in range(n):
        acc[:] = 0.0
        q = Q - 1
        for k in range(d - 1, -1, -1):
            xk = x[i, k] * inv[k]
            for j in range(N):
                e = xk - ps[k, j]
                acc[j] += e * e
            if q < 0 or k != starts[q]:
                continue
            row = t[q, i]
            for j in range(N):
                row[j] = log_weights[j] - 0.5 * acc[j]
            mi = -np.inf
            if clean:                       # a select: vectorised, ~2x the speed
                for j in range(N):
                    mi = row[j] if row[j] > mi else mi
            else:
                for j in range(N):
                    if row[j] > mi or row[j] != row[j]:     # a NaN row stays NaN
                        mi = row[j]
            m[q, i] = mi
            if np.isfinite(mi):
                for j in range(N):
                    v = row[j] - mi
                    row[j] = v if v > floor else floor
            else:
                row[:] = 0.0
            q -= 1
    return t, m


def walk_predictives(x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                     sigma: np.ndarray, starts: tuple[int, ...] = (0,)) -> np.ndarray:
    """:func:`walk_predictive` over the trailing dimensions from each of ``starts``
    (ascending): ``(len(starts), n)``, the tables of :func:`walk_tables`, summed by one
    matrix product."""
    sigma = np.ascontiguousarray(sigma, float)
    st = np.asarray(starts, np.int64)
    if (st.ndim != 1 or not len(st) or st[0] < 0 or st[-1] >= len(sigma)
            or np.any(np.diff(st) <= 0)):
        # the kernel fills table q when its backward sum reaches starts[q]: unsorted or
        # out-of-range starts would leave tables unwritten
        raise ValueError(f"starts must ascend strictly within [0, {len(sigma)}), got {starts}")
    t, m = walk_tables(np.ascontiguousarray(x, float), np.ascontiguousarray(particles, float),
                       np.ascontiguousarray(log_weights, float), sigma,
                       st, EXP_FLOOR)
    log_sigma = np.log(sigma)
    const = np.array([np.sum(log_sigma[s:]) + 0.5 * (len(sigma) - s) * _LOG_2PI
                      for s in starts])[:, None]
    out = np.log(np.exp(t, out=t) @ np.ones(t.shape[2]))         # row sums: gemv, 3x np.sum's
    out += m
    out -= const
    return np.where(np.isfinite(m), out, m - const)


def walk_densities(x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                   sigma: np.ndarray) -> np.ndarray:
    """:func:`walk_predictives` of the 9-D hand state over the whole state, the orientation
    and semi-axes, and the semi-axes (``f``, ``f_oa``, ``f_a``, ``(3, n)``): the dynamics'
    predictive density (:meth:`PoseReset.predictive_log_density`) and the importance
    function's (:meth:`CandidateProposal.log_density`) share ``f_a`` and the distances."""
    return walk_predictives(x, particles, log_weights, sigma, (POS.start, ORI.start,
                                                              AXES.start))


class WalkDensities:
    """:func:`walk_densities` keeping its last call: ICONDENSATION asks the dynamics and the
    importance function for their densities at the same particles, so a tracker gives both
    one of these and the tables are built once a frame (equal arguments, compared by value,
    return the kept result)."""

    def __init__(self):
        self._last: tuple | None = None

    def __call__(self, x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                 sigma: np.ndarray) -> np.ndarray:
        args = (x, particles, log_weights, sigma)
        last = self._last
        if last is not None and all(np.array_equal(a, b)
                                    for a, b in zip(args, last[0], strict=True)):
            return last[1]
        out = walk_densities(*args)
        out.setflags(write=False)
        self._last = (tuple(np.array(a, float) for a in args), out)
        return out


def walk_predictive(x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                    sigma: np.ndarray) -> np.ndarray:
    """``log sum_j w_j N(x_i; x_j, diag(sigma^2))`` for every row of ``x (n, d)``: a random
    walk's predictive density from weighted ``particles (N, d)`` (normalised ``log_weights``),
    the ``(n, N)`` table from :func:`walk_tables` (:func:`walk_predictive_numpy` is the array
    form; ~2x faster at 100 x 100)."""
    return walk_predictives(x, particles, log_weights, sigma)[0]


def walk_predictive_numpy(x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                    sigma: np.ndarray) -> np.ndarray:
    """``log sum_j w_j N(x_i; x_j, diag(sigma^2))`` for every row of ``x (n, d)``: a random
    walk's predictive density from weighted ``particles (N, d)`` (normalised ``log_weights``),
    i.e. :func:`logsumexp` of ``RandomWalk(sigma).pairwise_log_density(x, particles) +
    log_weights`` with the ``(n, N)`` table built and reduced in place (``-|x_i - x_j|^2 / 2``
    as ``x_i . x_j - |x_i|^2 / 2 - |x_j|^2 / 2`` in the scaled coordinates; equal to rounding,
    a third fewer passes over the table)."""
    xs, ps = x / sigma, particles / sigma
    t = xs @ ps.T
    t -= 0.5 * np.einsum("ij,ij->i", xs, xs)[:, None]
    t += (log_weights - 0.5 * np.einsum("ij,ij->i", ps, ps))[None]
    m = t.max(axis=1, keepdims=True)
    const = float(np.sum(np.log(sigma))) + 0.5 * len(sigma) * _LOG_2PI
    if not np.isfinite(m).all():                     # a row with no finite term
        return logsumexp(t, axis=1) - const
    t -= m
    np.maximum(t, EXP_FLOOR, out=t)
    return np.log(np.sum(np.exp(t, out=t), axis=1)) + (m[:, 0] - const)


@dataclass(frozen=True)
class PoseReset:
    """``(1 - eps) RW(x) + eps U(p, o) RW(axes)``: a random walk, or with probability ``eps``
    centre and orientation re-drawn from ``box`` (6-D) while the semi-axes walk on."""

    walk: RandomWalk
    box: UniformBox
    eps: float
    densities: WalkDensities = field(default_factory=WalkDensities, compare=False)
    """Shared with the frame's :class:`CandidateProposal` (:class:`WalkDensities`)."""

    def __post_init__(self):
        object.__setattr__(self, "_walk_axes", RandomWalk(self.walk.sigma[AXES]))

    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        out = self.walk.sample(x, rng)
        idx = np.flatnonzero(rng.random(len(x)) < self.eps)
        out[idx, POSE] = self.box.sample(len(idx), rng)
        return out

    def _axes(self) -> RandomWalk:
        return self._walk_axes

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        x_new, x_old = np.asarray(x_new, float), np.asarray(x_old, float)
        a = math.log1p(-self.eps) + self.walk.log_density(x_new, x_old)
        b = (math.log(self.eps) + self.box.log_density(x_new[..., POSE])
             + self._axes().log_density(x_new[..., AXES], x_old[..., AXES]))
        return np.logaddexp(a, b)

    def pairwise_log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        x_new, x_old = np.asarray(x_new, float), np.asarray(x_old, float)
        a = math.log1p(-self.eps) + self.walk.pairwise_log_density(x_new, x_old)
        b = (math.log(self.eps) + self.box.log_density(x_new[:, POSE])[:, None]
             + self._axes().pairwise_log_density(x_new[:, AXES], x_old[:, AXES]))
        return np.logaddexp(a, b)

    def predictive_log_density(self, x: np.ndarray, particles: np.ndarray,
                               log_weights: np.ndarray) -> np.ndarray:
        """``log sum_j w_j p(x | x_j) = log((1 - eps) f(x) + eps U(p, o) f_a(a))`` with ``f``
        and ``f_a`` the random walks' predictive densities over the whole state and over the
        semi-axes (normalised weights): two ``(n, N)`` tables reduced by rows, no table-wide
        ``logaddexp``."""
        x = np.asarray(x, float)
        f, _, f_a = self.densities(x, particles, log_weights, self.walk.sigma)
        return np.logaddexp(math.log1p(-self.eps) + f,
                            math.log(self.eps) + self.box.log_density(x[:, POSE]) + f_a)

    def mean(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, float)


@dataclass(frozen=True)
class CandidateProposal:
    """``pi(x) = pi_3d(p) [(1 - fresh) f(o, a) + fresh U(o) f(a)]`` with ``f`` the particle
    set's predictive density (random walk ``walk`` from weighted ``particles``; the
    normalised ``log_weights`` that ICONDENSATION's dynamics see, so that the shared
    :class:`WalkDensities` computes ``f(a)`` once for both)."""

    positions: Mixture
    particles: np.ndarray
    log_weights: np.ndarray
    walk: RandomWalk
    orientations: UniformBox
    fresh: float = 0.5
    densities: WalkDensities = field(default_factory=WalkDensities, compare=False)
    """The dynamics' (:attr:`PoseReset.densities`): ``f(a)`` computed once for both."""

    @property
    def empty(self) -> bool:
        return self.positions.empty

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        anc = resample_indices(self.log_weights, rng, "systematic", n)
        out = self.walk.sample(self.particles[anc], rng)
        out[:, POS] = self.positions.sample(n, rng)
        new = rng.random(n) < self.fresh
        if new.any():
            out[new, ORI] = self.orientations.sample(int(new.sum()), rng)
        return out

    def log_density(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        _, f_oa, f_a = self.densities(x, self.particles, self.log_weights, self.walk.sigma)
        with np.errstate(divide="ignore"):
            mix = np.logaddexp(math.log1p(-self.fresh) + f_oa if self.fresh < 1 else -np.inf,
                               math.log(self.fresh) + self.orientations.log_density(x[:, ORI])
                               + f_a if self.fresh > 0 else -np.inf)
        return self.positions.log_density(x[:, POS]) + mix
