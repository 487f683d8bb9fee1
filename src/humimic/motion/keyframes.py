"""Keyframed motion: each channel (a palm, the head, a joint) interpolated through its keys.

A channel's keys are the frames that specify it. Interpolation (per channel, per component):

* ``spline``: C2 cubic spline through the keys, first derivative zero at the first and last key
  ("clamped" ends), so the channel starts and ends at rest and does not stop at inner keys;
* ``min_jerk``: between consecutive keys the minimum-jerk quintic ``10u^3 - 15u^4 + 6u^5``,
  so the channel is at rest (zero velocity and acceleration) at every key.

Before its first key a channel holds the first value, after its last key the last value. A
channel with a single key is constant. Ball joints are interpolated as rotation vectors.
Palm targets are then solved by arm IK, head targets by torso lean + body shift
(:mod:`humimic.motion.pose`).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from humimic.motion.config import KeyframesMotion
from humimic.motion.context import MotionContext
from humimic.motion.primitives import Path, TargetMotion, min_jerk


def channel_path(times: np.ndarray, values: np.ndarray, method: str) -> Path:
    """Interpolating function ``t (N,) -> (N, D)`` through keys ``values (K, D)`` at ``times``."""
    times = np.asarray(times, float)
    values = np.asarray(values, float).reshape(len(times), -1)
    if len(times) == 1:
        return lambda t: np.broadcast_to(values[0], (len(t), values.shape[1])).copy()
    t0, t1 = times[0], times[-1]
    if method == "spline":
        spline = CubicSpline(times, values, bc_type="clamped", axis=0)
        return lambda t: spline(np.clip(t, t0, t1))
    if method == "min_jerk":
        def path(t: np.ndarray) -> np.ndarray:
            tc = np.clip(t, t0, t1)
            i = np.clip(np.searchsorted(times, tc, side="right") - 1, 0, len(times) - 2)
            u = (tc - times[i]) / (times[i + 1] - times[i])
            return values[i] + min_jerk(u)[:, None] * (values[i + 1] - values[i])
        return path
    raise ValueError(f"unknown interpolation {method!r}")


def keyframe_channels(c: KeyframesMotion) -> tuple[dict[str, Path], dict[str, Path]]:
    """(target paths, joint paths) for a keyframes config."""
    targets: dict[str, Path] = {}
    for key in ("right_hand", "left_hand", "head"):
        keys = [(f.t, getattr(f, key)) for f in c.frames if getattr(f, key) is not None]
        if keys:
            ts, vs = zip(*keys, strict=True)
            targets[key] = channel_path(np.array(ts), np.array(vs), c.interpolation)
    joints: dict[str, Path] = {}
    for name in dict.fromkeys(j for f in c.frames for j in f.joints):
        keys = [(f.t, f.joints[name]) for f in c.frames if name in f.joints]
        ts, vs = zip(*keys, strict=True)
        path = channel_path(np.array(ts), np.array(vs, float), c.interpolation)
        scalar = np.ndim(vs[0]) == 0
        joints[name] = (lambda p: lambda t: p(t)[:, 0])(path) if scalar else path
    return targets, joints


def make_keyframes(c: KeyframesMotion, ctx: MotionContext) -> TargetMotion:
    targets, joints = keyframe_channels(c)
    return TargetMotion(ctx.geometry, targets, head_lean=c.head_lean,
                        palm_dir=ctx.palm_direction, joint_paths=joints)
