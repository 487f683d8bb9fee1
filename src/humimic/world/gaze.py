"""Point the robot's eyes (and, if needed, its head) at a point: closed-form pan/tilt angles."""

from __future__ import annotations

import math

import numpy as np


def pan_tilt_to(p_eye_target: np.ndarray) -> tuple[float, float]:
    """Eye pan (about z, + left) and tilt (about -y, + up) that aim the eye's +x at a point.

    ``p_eye_target`` is the target in the eye's *parent* frame, relative to the eye centre.
    Pan is applied first, then tilt (the robot's joint order).
    """
    x, y, z = p_eye_target
    pan = math.atan2(y, x)
    tilt = math.atan2(z, math.hypot(x, y))
    return pan, tilt
