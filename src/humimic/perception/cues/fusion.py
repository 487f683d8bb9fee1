"""Fusing independent cues (Menezes eq. 7): ``p(z^1..z^M|x) ∝ prod_m p(z^m|x)`` -- in logs, a
sum over the cues of per-particle log-likelihoods."""

from __future__ import annotations

import numpy as np


def fuse(*log_likelihoods: np.ndarray) -> np.ndarray:
    """Menezes eq. 7: the sum of the cues' log-likelihoods ``(N,)`` (each up to a constant)."""
    if not log_likelihoods:
        raise ValueError("fuse needs at least one cue")
    out = np.zeros(np.shape(log_likelihoods[0]))
    for ll in log_likelihoods:
        out = out + np.asarray(ll, dtype=np.float64)  # Menezes eq. 7
    return out
