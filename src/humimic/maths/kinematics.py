"""Constant-acceleration prediction: the one motion model every family extrapolates with."""

from __future__ import annotations

import numpy as np


def ca_predict(p, v, a, dt) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration ``dt`` seconds ahead under constant acceleration
    (the mean of the random-jerk model, Ude eq. 13): ``p + v dt + a dt^2/2``, ``v + a dt``,
    ``a``. ``p, v, a`` are ``(3,)`` or ``(N, 3)``; ``dt`` a scalar or ``(N,)``."""
    p, v, a = (np.asarray(x, dtype=float) for x in (p, v, a))
    dt = np.asarray(dt, dtype=float)
    if dt.ndim:  # one dt per row: (N,) against (N, 3) or (3,)
        dt = dt[..., None]
    return p + v * dt + 0.5 * a * dt * dt, v + a * dt, a
