"""The kernel particle filter (Schmidt, Fritsch & Kwolek sec. 5.2, after Chang & Ansari 2005):
kernel density estimate of the weighted particle set with the Epanechnikov kernel, mean-shift
mode seeking with a shrinking bandwidth, reweighting after each shift, the dominant mode, and
mixed propagation (a linear motion model for part of the particles, random walk for the rest).

Bandwidths are per dimension (``h`` a ``(d,)`` vector, Schmidt's ``h0 = D``): distances are
``||(x - s) / h||``, i.e. the kernel of eq. 11 in coordinates scaled by ``h``. Everything is
pure and vectorised over particles; randomness comes in as a ``numpy.random.Generator``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from humimic.estimation.particles.resampling import indices_from_weights
from humimic.estimation.particles.weights import weights_columns
from humimic.maths.jit import njit


def sq_distances(x: np.ndarray, s: np.ndarray, h: np.ndarray, dtype=np.float64,
                 clip: bool = True) -> np.ndarray:
    """``(M, N)`` squared scaled distances ``||(x_m - s_n) / h||^2``: one matrix product of the
    augmented rows ``[a, 1, |a|^2] . [-2 b, |b|^2, 1]`` (one ``(M, N)`` array allocated: fresh
    large arrays cost more than the arithmetic), in ``dtype`` (``float32``: half the memory
    traffic; both point sets are first centred on ``s``'s mean, so ``|a|^2`` and ``|b|^2`` stay
    of the order of the spread and the cancellation error near a distance of 1 is ~1e-6).
    ``clip=False``: the few that round below 0 are left so (:func:`clip_negative`), for a
    caller that only compares them with a positive bound or clips them itself."""
    c = s.mean(axis=0) if len(s) else 0.0
    return _sq_scaled((x - c) / h, (s - c) / h, dtype, clip)


def _sq_scaled(a: np.ndarray, b: np.ndarray, dtype, clip: bool = True) -> np.ndarray:
    """``(..., M, N)`` ``||a_m - b_n||^2`` of centred, scaled points ``a (..., M, d)``,
    ``b (..., N, d)`` (:func:`sq_distances`; leading axes batched; ``b is a``: their squared
    norms computed once)."""
    d = a.shape[-1]
    A, B = np.empty(a.shape[:-1] + (d + 2,), dtype), np.empty(b.shape[:-1] + (d + 2,), dtype)
    a2 = np.einsum("...j,...j->...", a, a)
    A[..., :d], A[..., d], A[..., d + 1] = a, 1.0, a2
    B[..., :d], B[..., d] = -2.0 * b, a2 if b is a else np.einsum("...j,...j->...", b, b)
    B[..., d + 1] = 1.0
    d2 = A @ np.swapaxes(B, -1, -2)
    return clip_negative(d2) if clip else d2


def clip_negative(x: np.ndarray) -> np.ndarray:
    """``x`` with its negative entries set to 0, in place (squared distances from the
    augmented product of :func:`_sq_scaled` may round below 0)."""
    return np.maximum(x, 0.0, out=x)


def epanechnikov_profile(r2: np.ndarray) -> np.ndarray:
    """The Epanechnikov profile ``max(1 - r2, 0)`` of squared distances ``r2``, in place and
    unnormalised, the same whether ``r2`` was :func:`clip_negative`-d or not (``1 - r2``
    clipped to ``[0, 1]``: one pass fewer than clipping ``r2`` first)."""
    np.subtract(1.0, r2, out=r2)
    return np.clip(r2, 0.0, 1.0, out=r2)


def unique_rows(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the distinct rows of ``q (N, d)`` and, per row, which of them it equals: rows
    keyed by a fixed random projection (a 1-D sort, ~10x faster than ``np.unique(axis=0)``),
    checked exactly (falls back to ``np.unique(axis=0)`` if two distinct rows share a key)."""
    key = q @ _KEY[: q.shape[1]] if q.shape[1] <= len(_KEY) else q.sum(1)
    # np.unique(key, return_index=True, return_inverse=True) without its Python overhead:
    # a stable sort, the first of each run of equal keys (compiled, with the exact check)
    order = np.argsort(key, kind="stable")
    first, inverse, exact = _key_runs(np.ascontiguousarray(q, float),
                                      np.ascontiguousarray(key, float), order)
    if not exact:
        _, first, inverse = np.unique(q, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.reshape(-1)
    return first, inverse


@njit
def _key_runs(q, key, order):
    """:func:`unique_rows`' runs of equal keys in the sorted ``order``: ``first`` (the first
    row of each run, in run order), ``inverse`` (each row's run), and whether every row equals
    its run's first row exactly (NaN never does)."""
    n = len(order)
    inverse = np.empty(n, np.intp)
    first = np.empty(n, np.intp)
    runs = 0
    for i in range(n):
        r = order[i]
        if i == 0 or key[r] != key[order[i - 1]]:
            first[runs] = r
            runs += 1
        inverse[r] = runs - 1
    exact = True
    for r in range(n):
        f = first[inverse[r]]
        for c in range(q.shape[1]):
            if q[r, c] != q[f, c]:
                exact = False
    return first[:runs].copy(), inverse, exact


_KEY = np.random.default_rng(20071).normal(size=64)


#: Kernel matrices smaller than this many entries are computed without looking for coinciding
#: rows (finding them costs ~0.1 ms, as much as a 150 x 150 matrix).
DEDUP_MIN = 100_000


def _distinct(x: np.ndarray, other: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`unique_rows` of ``x`` when a kernel matrix of ``len(x) x other`` is large enough
    to be worth it, else ``None, None`` (every row)."""
    if len(x) * other < DEDUP_MIN:
        return None, None
    return unique_rows(x)


def merge_rows(s: np.ndarray, w: np.ndarray, other: int = DEDUP_MIN) -> tuple[np.ndarray,
                                                                            np.ndarray]:
    """Weighted points ``s (N, d)``, ``w (N,)`` with coinciding rows merged (their weights
    summed): every kernel sum ``sum_n K(x - s_n) w_n`` is the same over the merged set (mean
    shift moves whole windows of particles onto one point). Left as they are when the kernel
    matrix against ``other`` points is small (:data:`DEDUP_MIN`)."""
    first, inverse = _distinct(s, other)
    if first is None or len(first) == len(s):
        return s, w
    return s[first], np.bincount(inverse, weights=w, minlength=len(first))


def epanechnikov_norm(d: int) -> float:
    """``c_d``, the volume of the unit ``d``-ball (Schmidt eq. 12's normalisation)."""
    return math.pi ** (d / 2) / math.gamma(d / 2 + 1)


def epanechnikov(r2: np.ndarray, d: int) -> np.ndarray:
    """Schmidt eq. 12: ``K_E(x) = (d + 2) / (2 c_d) (1 - ||x||^2)`` inside the unit ball, of
    the squared norm ``r2``; it integrates to one over R^d."""
    return (d + 2) / (2.0 * epanechnikov_norm(d)) * np.maximum(1.0 - r2, 0.0)


def epanechnikov_inplace(r2: np.ndarray, d: int) -> np.ndarray:
    """:func:`epanechnikov` overwriting the float array ``r2`` (no temporaries; ``r2`` need
    not be clipped at 0, :func:`epanechnikov_profile`)."""
    epanechnikov_profile(r2)
    r2 *= (d + 2) / (2.0 * epanechnikov_norm(d))
    return r2


def _bandwidth(h, d: int) -> np.ndarray:
    """``h`` (a scalar or per-dimension bandwidths) as ``(d,)`` floats (read, not written)."""
    if type(h) is np.ndarray and h.dtype == np.float64 and h.shape == (d,):
        return h             # already so (the common case: no broadcast_to's overhead)
    return np.broadcast_to(np.asarray(h, float), (d,))


#: Weights below this fraction of the largest are left out of weighted sums (their share of
#: any sum is below N times it): mean shift and weighted KDEs then cost N x (heavy particles).
NEGLIGIBLE = 1e-7


def heavy(w: np.ndarray, rel: float = NEGLIGIBLE) -> np.ndarray:
    """Indices of the weights above ``rel`` times the largest."""
    return np.flatnonzero(w > rel * np.max(w, initial=0.0))


def kde(x: np.ndarray, particles: np.ndarray, w: np.ndarray, h: np.ndarray,
        dtype=np.float64) -> np.ndarray:
    """Schmidt eq. 11: ``p(x) = sum_n K_h(x - s_n) w_n`` with ``K_h(u) = K(u / h) / prod(h)``
    (normalised weights ``w``), at points ``x (M, d)`` (negligible weights left out, coinciding
    particles and points computed once; kernel sums in ``dtype``)."""
    w = np.asarray(w, float)
    keep = heavy(w)
    src, wk = merge_rows(particles[keep], w[keep], len(x))
    first, inverse = _distinct(x, len(src))
    p = _kernel_sums(x if first is None else x[first], src, wk[:, None], h, dtype)[:, 0]
    return p if first is None else p[inverse]


def _kernel_sums(x: np.ndarray, src: np.ndarray, W: np.ndarray, h, dtype) -> np.ndarray:
    """``(M, S)`` ``sum_n K_h(x_m - src_n) W[n, s]`` (eq. 11 per weight column)."""
    d = x.shape[1]
    h = _bandwidth(h, d)
    r2 = sq_distances(x, src, h, dtype, clip=False)
    return (epanechnikov_inplace(r2, d) @ W.astype(dtype)).astype(float) / np.prod(h)


def mean_shift(particles: np.ndarray, w: np.ndarray, h: np.ndarray, dtype=np.float64
               ) -> np.ndarray:
    """Schmidt eq. 13: every particle moved to ``m(s) = sum H(s_i - s) w_i s_i / sum H w_i``.
    ``H``'s profile is ``-k'``: for the Epanechnikov kernel a constant inside the bandwidth
    (the flat kernel), so ``m(s)`` is the weighted mean of the particles within ``h`` of ``s``
    (a particle with no weighted particle in its window stays put). Coinciding particles are
    shifted once and merged as sources (their weights summed); sums in ``dtype``, of the
    sources' offsets from their weighted mean (in units of ``h``)."""
    h = _bandwidth(h, particles.shape[1])
    keep = heavy(w)
    if len(keep) == 0:
        return particles.copy()
    first, inverse = _distinct(particles, len(keep))
    if first is None:
        at, src, wk = particles, particles[keep], w[keep]
    else:   # the distinct particles; as sources, those holding heavy ones, weights summed
        at = particles[first]
        wsum = np.bincount(inverse[keep], weights=w[keep], minlength=len(first))
        nz = np.flatnonzero(wsum > 0.0)
        src, wk = at[nz], wsum[nz]
    inside = sq_distances(at, src, h, dtype, clip=False)   # (M, K); only compared with 1
    np.less_equal(inside, 1.0, out=inside, casting="unsafe")            # 1.0 inside, in place
    c = wk @ src / wk.sum()
    sums = inside @ np.column_stack([wk[:, None] * ((src - c) / h), wk]).astype(dtype)
    num, den = sums[:, :-1].astype(float), sums[:, -1].astype(float)
    stay = den <= 0.0
    out = c + h * (num / np.where(stay, 1.0, den)[:, None])
    out[stay] = at[stay]
    return out if first is None else out[inverse]


def kernel_log_weights(log_lik: np.ndarray, shifted: np.ndarray, prior: np.ndarray,
                       h: np.ndarray, stride: int = 1, dtype=np.float64) -> np.ndarray:
    """Reweighting after a mean shift (Chang & Ansari eq. 9, which Schmidt follows): shifted
    samples are no longer drawn from the prior, so ``w ∝ p(y|s) p(s) / q(s)`` with the prior
    ``p`` the KDE (eq. 11) of the predicted particles ``prior`` (equally weighted, before any
    shift) and the proposal ``q`` the KDE of the shifted ones. Unnormalised log-weights
    (``-inf`` where the prior's KDE is 0). ``stride > 1`` estimates both KDEs from every
    ``stride``-th particle (a Monte Carlo estimate, ``N / stride`` kernels per point instead of
    N), keeping each sample's own kernel in ``q`` so it stays positive. Kernel sums in
    ``dtype``; coinciding samples computed once."""
    n, d = shifted.shape
    h = _bandwidth(h, d)
    ref_p, ref_q = prior[::stride], shifted[::stride]
    # one kernel matrix: the prior's particles | the shifted ones (coinciding ones merged)
    first, inverse = _distinct(shifted, len(ref_p) + len(ref_q))
    if first is None:
        at, src_q, w_q = shifted, ref_q, np.full(len(ref_q), 1.0 / len(ref_q))
    else:
        at = shifted[first]
        counts = np.bincount(inverse[::stride], minlength=len(first))
        nz = np.flatnonzero(counts)
        src_q, w_q = at[nz], counts[nz] / len(ref_q)
    W = np.zeros((len(ref_p) + len(src_q), 2))
    W[:len(ref_p), 0], W[len(ref_p):, 1] = 1.0 / len(ref_p), w_q
    pq = _kernel_sums(at, np.concatenate([ref_p, src_q]), W, h, dtype)
    p, q = (pq if first is None else pq[inverse]).T       # q > 0 at stride 1 (own kernel)
    if stride > 1:
        q = q * (1.0 - 1.0 / n) + epanechnikov(0.0, d) / np.prod(h) / n
    with np.errstate(divide="ignore"):
        return log_lik + np.log(p) - np.log(q)


def dominant_mode(particles: np.ndarray, w: np.ndarray, h: np.ndarray, window: np.ndarray,
                  dtype=np.float64) -> tuple[np.ndarray, int]:
    """The dominant mode (Schmidt sec. 5.2): the particle where the posterior's KDE (eq. 11)
    peaks, then the weighted mean of the particles within ``window`` (scaled distance <= 1) of
    it. Returns the mode ``(d,)`` and the peak particle's index. Only particles of
    non-negligible weight are candidates for the peak (the others' KDE value is no larger)."""
    keep = heavy(w)
    peak = int(keep[np.argmax(kde(particles[keep], particles, w, h, dtype))])
    near = sq_distances(particles[peak:peak + 1], particles, window, clip=False)[0] <= 1.0
    wn = w * near
    if wn.sum() <= 0.0:
        return particles[peak].copy(), peak
    return wn @ particles / wn.sum(), peak


def motion_share(w: np.ndarray, moved: np.ndarray, min_random: float) -> float:
    """Share of next step's particles for the motion model: its group's cumulated posterior
    weight, leaving the random group at least ``min_random`` (Schmidt sec. 5.2)."""
    total = w.sum()
    share = float(w[moved].sum() / total) if total > 0 else 0.5
    return min(max(share, 0.0), 1.0 - min_random)


def mixed_propagate(particles: np.ndarray, velocity: np.ndarray, share: float, D: np.ndarray,
                    rng: np.random.Generator, valid: Callable[[np.ndarray], np.ndarray],
                    motion_scale: float = 0.25, retries: int = 10,
                    shape: np.ndarray | None = None, shape_groups: str = "both"
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Schmidt sec. 5.2's mixed propagation of resampled particles ``(N, d)``: the first
    ``round(share N)`` through the linear motion model ``s + velocity`` (velocity: the last
    two best modes' difference) with uniform noise of half-width ``motion_scale D``, the rest
    by a random walk with uniform noise of half-width ``D`` (the paper's "variance D", read as
    the noise's extent); a particle outside ``valid`` is re-drawn (up to ``retries`` times,
    then left to the caller's clamp). ``velocity`` ``(d,)``, or ``(N, d)`` one per particle.
    ``shape`` ``(d, d)`` (optional): every particle's noise ``n`` becomes ``shape @ n``
    (``shape_groups``: ``both`` groups', or only the ``random`` or the ``motion`` group's,
    the other's noise left whole).
    Returns the particles and the motion-model mask."""
    n = len(particles)
    moved = np.arange(n) < int(round(share * n))
    half = np.where(moved[:, None], motion_scale * D, D)
    base = particles + np.where(moved[:, None], velocity, 0.0)
    T = None if shape is None else np.asarray(shape, float).T

    shaped = {"both": np.ones(n, bool), "random": ~moved, "motion": moved}[shape_groups]

    def noise(u: np.ndarray, h: np.ndarray, rows: np.ndarray) -> np.ndarray:
        u = u * h
        if T is not None:
            u[rows] = u[rows] @ T
        return u

    out = base + noise(rng.uniform(-1.0, 1.0, base.shape), half, shaped)
    for _ in range(retries):
        bad = ~valid(out)
        if not bad.any():
            break
        out[bad] = base[bad] + noise(rng.uniform(-1.0, 1.0, (int(bad.sum()), base.shape[1])),
                                     half[bad], shaped[bad])
    return out, moved


def kpf_modes(particles: np.ndarray, log_lik_fn: Callable[[np.ndarray], np.ndarray],
              h0: np.ndarray, iterations: int, tol: float = 1e-3, shrink: float = 0.8,
              reweight: bool = True, groups: list[np.ndarray] | None = None,
              stride: int = 1, prior: np.ndarray | None = None, dtype=np.float64
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Mean-shift mode seeking of a predicted particle set (Schmidt sec. 5.2): weight by the
    likelihood, then up to ``iterations`` times shift every particle (eq. 13, bandwidth
    ``h = shrink^i h0``) and reweight (:func:`kernel_log_weights` with ``stride``, or the
    likelihood alone with ``reweight=False``); stop early when the best particle moves less
    than ``tol`` (scaled by ``h0``).

    ``groups`` (default: one group of every dimension) partitions the dimensions; then
    ``log_lik_fn`` returns ``(N, G)``, column ``g`` the log-likelihood terms that group ``g``'s
    dimensions affect (e.g. a torso group with the whole pose's, an arm group with that arm's
    limbs), and each group is shifted and reweighted with its own weights over its own
    dimensions (a product kernel). Returns particles, normalised weights ``(N, G)``,
    log-likelihoods ``(N, G)`` and the iterations done. ``prior`` (default: ``particles``) are
    samples of the prior whose KDE the reweighting uses, when ``particles`` were drawn from
    another proposal (e.g. some of them moved along a direction the dynamics rarely take).
    ``dtype``: of the kernel sums (:func:`mean_shift`, :func:`kernel_log_weights`)."""
    from humimic.estimation.particles.kernel_groups import (
        kernel_log_weights_groups,
        mean_shift_groups,
    )

    d = particles.shape[1]
    groups = [np.arange(d)] if groups is None else [np.asarray(g) for g in groups]
    h0 = _bandwidth(h0, d)

    def lik_of(x):
        return np.asarray(log_lik_fn(x), float).reshape(len(x), len(groups))

    lik = lik_of(particles)
    W = weights_columns(lik)
    prior = particles if prior is None else prior
    done = 0
    for i in range(iterations):
        h = shrink ** i * h0
        best = particles[np.argmax(W, axis=0), :]
        shifted = mean_shift_groups(particles, W, h, groups, dtype)
        lik = lik_of(shifted)
        lw = (kernel_log_weights_groups(lik, shifted, prior, h, groups, stride, dtype)
              if reweight else lik)
        W = weights_columns(lw)
        particles, done = shifted, i + 1
        step = (particles[np.argmax(W, axis=0), :] - best) / h0    # (G, d): each group's best
        moved = [math.sqrt(np.dot(v, v)) for v in (step[k, g] for k, g in enumerate(groups))]
        if max(moved) < tol:
            break
    return particles, W, lik, done


def partitioned_resample(particles: np.ndarray, W: np.ndarray, groups: list[np.ndarray],
                         rng: np.random.Generator) -> np.ndarray:
    """Resample each group's dimensions with its own weights ``W[:, g]`` (systematic), the
    groups independently: partitioned sampling's recombination (MacCormick & Isard 2000) for
    groups whose likelihood terms do not interact."""
    return partitioned_take(particles, partitioned_resample_indices(W, groups, rng), groups)


def partitioned_resample_indices(W: np.ndarray, groups: list[np.ndarray],
                                 rng: np.random.Generator) -> np.ndarray:
    """``(N, G)`` :func:`partitioned_resample`'s ancestor index per particle and group
    (systematic, one uniform per group in the groups' order; the weights normalised in one
    pass, :func:`~humimic.estimation.particles.weights.weights_columns`, as
    :func:`~humimic.estimation.particles.resampling.resample_indices` would per group)."""
    w = weights_columns(np.log(np.maximum(W[:, :len(groups)], 1e-300)))
    return np.stack([indices_from_weights(w[:, k], rng) for k in range(len(groups))], axis=1)


def partitioned_take(x: np.ndarray, idx: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """Rows of ``x (N, d)`` picked per group: ``out[:, g] = x[idx[:, k]][:, g]`` (anything
    carried per particle, e.g. the particles themselves or their velocities)."""
    out = np.empty_like(x)
    for k, g in enumerate(groups):
        out[:, g] = x[idx[:, k]][:, g]
    return out
