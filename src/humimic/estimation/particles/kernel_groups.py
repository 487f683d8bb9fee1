"""The kernel particle filter's kernel sums for a state partitioned into groups of dimensions
(partitioned mode seeking: each group shifted, reweighted and its mode taken with its own
weights, a product kernel over the groups), as :mod:`humimic.estimation.particles.kernel`'s
functions per group. Small sets (kernel matrices under :data:`~kernel.DEDUP_MIN` entries, where
numpy's per-call overhead outweighs the arithmetic) run all groups in one stacked pass: each
group's dimensions zero-padded to the largest group's (padding adds nothing to a distance),
negligible weights set to 0 instead of left out; equal to the per-group functions to the
kernel sums' rounding.
"""

from __future__ import annotations

import numpy as np

from humimic.estimation.particles.kernel import (
    DEDUP_MIN,
    NEGLIGIBLE,
    _bandwidth,
    _sq_scaled,
    dominant_mode,
    epanechnikov,
    epanechnikov_profile,
    kernel_log_weights,
    mean_shift,
)


def _group_coords(x: np.ndarray, groups: list[np.ndarray], h: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Each group's dimensions of ``x (N, d)`` as ``(G, N, dm)`` (``dm`` the largest group;
    shorter groups padded with zeros, which add nothing to a distance) and the bandwidths
    ``(G, 1, dm)`` (1 at the padding)."""
    dm = max(len(g) for g in groups)
    X, H = np.zeros((len(groups), len(x), dm)), np.ones((len(groups), 1, dm))
    for k, g in enumerate(groups):
        X[k, :, :len(g)], H[k, 0, :len(g)] = x[:, g], h[g]
    return X, H


def _batched(n: int, other: int, groups: list[np.ndarray]) -> bool:
    """Several groups' kernel matrices small enough (:data:`DEDUP_MIN`, no merging of
    coinciding rows) to run as one stacked product: the per-call overhead dominates there."""
    return len(groups) > 1 and n * other < DEDUP_MIN


def mean_shift_groups(particles: np.ndarray, W: np.ndarray, h: np.ndarray,
                      groups: list[np.ndarray], dtype=np.float64) -> np.ndarray:
    """:func:`mean_shift` of each group's dimensions with its own weights ``W[:, k]`` (a
    product kernel: partitioned mode seeking); small sets in one stacked pass, the weights
    under :data:`NEGLIGIBLE` of a group's largest set to 0 (as :func:`heavy` leaves them
    out)."""
    n, d = particles.shape
    h = _bandwidth(h, d)
    out = particles.copy()
    if not _batched(n, n, groups):
        for k, g in enumerate(groups):
            out[:, g] = mean_shift(particles[:, g], W[:, k], h[g], dtype)
        return out
    X, H = _group_coords(particles, groups, h)                         # (G, N, dm)
    Wz = np.where(W > NEGLIGIBLE * W.max(axis=0), W, 0.0).T[:, :, None]   # (G, N, 1)
    total = Wz.sum(axis=1, keepdims=True)                              # (G, 1, 1)
    c = (Wz * X).sum(axis=1, keepdims=True) / np.where(total > 0.0, total, 1.0)
    a = (X - c) / H
    inside = _sq_scaled(a, a, dtype, clip=False)          # (G, N, N); only compared with 1
    np.less_equal(inside, 1.0, out=inside, casting="unsafe")
    sums = inside @ np.concatenate([Wz * a, Wz], axis=-1).astype(dtype)
    num, den = sums[..., :-1].astype(float), sums[..., -1:].astype(float)
    stay = den <= 0.0
    shifted = np.where(stay, X, c + H * (num / np.where(stay, 1.0, den)))
    for k, g in enumerate(groups):
        out[:, g] = shifted[k, :, :len(g)]
    return out


def kernel_log_weights_groups(log_lik: np.ndarray, shifted: np.ndarray, prior: np.ndarray,
                              h: np.ndarray, groups: list[np.ndarray], stride: int = 1,
                              dtype=np.float64) -> np.ndarray:
    """:func:`kernel_log_weights` of each group's dimensions with its own log-likelihoods
    ``log_lik[:, k]``: ``(N, G)``; small sets in one stacked pass."""
    n, d = shifted.shape
    h = _bandwidth(h, d)
    ref_p, ref_q = prior[::stride], shifted[::stride]
    if not _batched(n, len(ref_p) + len(ref_q), groups):
        return np.column_stack([
            kernel_log_weights(log_lik[:, k], shifted[:, g], prior[:, g], h[g], stride, dtype)
            for k, g in enumerate(groups)])
    X, H = _group_coords(shifted, groups, h)
    S, _ = _group_coords(np.concatenate([ref_p, ref_q]), groups, h)
    c = S.mean(axis=1, keepdims=True)
    k2 = _sq_scaled((X - c) / H, (S - c) / H, dtype, clip=False)      # (G, N, K)
    epanechnikov_profile(k2)                           # each group's constant applied below
    Wpq = np.zeros((len(S[0]), 2), dtype)
    Wpq[:len(ref_p), 0], Wpq[len(ref_p):, 1] = 1.0 / len(ref_p), 1.0 / len(ref_q)
    pq = (k2 @ Wpq).astype(float)                                      # (G, N, 2)
    scale = np.array([epanechnikov(0.0, len(g)) / np.prod(h[g]) for g in groups])
    p, q = pq[..., 0].T * scale, pq[..., 1].T * scale                  # (N, G)
    if stride > 1:
        q = q * (1.0 - 1.0 / n) + scale / n
    with np.errstate(divide="ignore"):
        return log_lik + np.log(p) - np.log(q)


def dominant_modes(particles: np.ndarray, W: np.ndarray, h: np.ndarray, window: np.ndarray,
                   groups: list[np.ndarray], dtype=np.float64) -> np.ndarray:
    """:func:`dominant_mode` of each group's dimensions with its own weights ``W[:, k]``: the
    state ``(d,)`` made of the groups' modes; small sets in one stacked pass (the KDE at
    every particle, the peak among those of non-negligible weight)."""
    n, d = particles.shape
    h, window = _bandwidth(h, d), _bandwidth(window, d)
    mode = np.empty(d)
    if not _batched(n, n, groups):
        for k, g in enumerate(groups):
            mode[g], _ = dominant_mode(particles[:, g], W[:, k], h[g], window[g], dtype)
        return mode
    X, H = _group_coords(particles, groups, h)
    heavy = W > NEGLIGIBLE * W.max(axis=0)
    Wz = np.where(heavy, W, 0.0).T[:, :, None]                         # (G, N, 1)
    c = X.mean(axis=1, keepdims=True)
    a = (X - c) / H
    k2 = _sq_scaled(a, a, dtype, clip=False)                          # (G, N, N)
    epanechnikov_profile(k2)           # a positive constant per group does not move a peak
    density = np.where(heavy.T, (k2 @ Wz.astype(dtype))[..., 0], -np.inf)   # (G, N)
    peak = np.argmax(density, axis=1)
    for k, g in enumerate(groups):
        near = np.sum(((particles[:, g] - particles[peak[k], g]) / window[g]) ** 2, 1) <= 1.0
        wn = W[:, k] * near
        mode[g] = (wn @ particles[:, g] / wn.sum() if wn.sum() > 0.0
                   else particles[peak[k], g])
    return mode
