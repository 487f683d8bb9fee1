"""Array helpers for the per-particle hot paths (likelihoods evaluated a few times per frame on
small arrays, where numpy's Python-level overhead costs more than the arithmetic)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def stack(arrays: Sequence[np.ndarray], axis: int = 0) -> np.ndarray:
    """``np.stack(arrays, axis)`` of equally shaped arrays: one ``np.empty`` and a copy per
    array (np.stack's own checks and reshapes cost ~3x more on arrays of a few hundred
    values)."""
    first = np.asarray(arrays[0])
    shape = first.shape
    ax = axis + len(shape) + 1 if axis < 0 else axis
    if not 0 <= ax <= len(shape):
        raise np.exceptions.AxisError(axis, len(shape) + 1)
    out = np.empty(shape[:ax] + (len(arrays),) + shape[ax:], np.result_type(*arrays))
    lead = (slice(None),) * ax
    for i, a in enumerate(arrays):
        a = np.asarray(a)
        if a.shape != shape:
            raise ValueError(f"stack: all arrays must have shape {shape}, got {a.shape}")
        out[(*lead, i)] = a
    return out
