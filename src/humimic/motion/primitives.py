"""Parametric motions: target paths as pure functions of time, solved onto the avatar by IK.

Every path is smooth (C-infinity or at least C2) so the joint trajectory has continuous
accelerations: oscillations fade in over ``ramp`` seconds with a minimum-jerk envelope,
point-to-point moves follow the minimum-jerk profile ``10u^3 - 15u^4 + 6u^5`` (Flash & Hogan).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from humimic.motion.arm_ik import arm_lengths
from humimic.motion.avatar import AvatarGeometry
from humimic.motion.config import (
    RIGHT_HAND_FIGURE8,
    RIGHT_HAND_FRONT,
    RIGHT_HAND_WAVE,
    AxesMotion,
    Figure8Motion,
    HeadSweepMotion,
    PointMotion,
    StaticMotion,
    WaveMotion,
    mirror,
)
from humimic.motion.context import PRIMITIVE_RATE, MotionContext
from humimic.motion.pose import PoseTargets, pose_diagnostics, solve_pose

Path = Callable[[np.ndarray], np.ndarray]
AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


# ---- profiles ---------------------------------------------------------------------------------
def min_jerk(u: np.ndarray) -> np.ndarray:
    """Minimum-jerk position profile on ``u`` clipped to [0, 1] (zero vel./acc. at both ends)."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u * u)


def fade_in(t: np.ndarray, ramp: float) -> np.ndarray:
    """Envelope rising from 0 at t <= 0 to 1 at t >= ramp (1 everywhere if ramp == 0)."""
    return np.ones_like(t) if ramp <= 0.0 else min_jerk(t / ramp)


def slerp_vectors(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Great-circle interpolation between unit vectors ``a`` and ``b`` (not antiparallel)."""
    omega = np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))
    s = np.asarray(s, float)[:, None]
    if omega < 1e-9:
        return np.broadcast_to(a, (len(s), 3)).copy()
    return (np.sin((1 - s) * omega) * a + np.sin(s * omega) * b) / np.sin(omega)


# ---- paths (pure) -----------------------------------------------------------------------------
def tremor_components(rng: np.random.Generator, rms: float, frequency: float,
                      n: int = 4) -> tuple[np.ndarray, np.ndarray, float]:
    """Random tremor: ``n`` frequencies within +-15 % of ``frequency``, random phases per axis,
    and a per-component amplitude giving ``rms`` per axis."""
    freqs = frequency * rng.uniform(0.85, 1.15, n)
    phases = rng.uniform(0.0, 2 * np.pi, (n, 3))
    return freqs, phases, rms * np.sqrt(2.0 / n)


def tremor(t: np.ndarray, freqs: np.ndarray, phases: np.ndarray, amp: float) -> np.ndarray:
    """(N, 3) tremor displacement: a sum of sinusoids."""
    arg = 2 * np.pi * freqs[None, :, None] * t[:, None, None] + phases[None]
    return amp * np.sin(arg).sum(axis=1)


def wave_path(t: np.ndarray, center: np.ndarray, amplitude: float, period: float,
              arc_radius: float, ramp: float) -> np.ndarray:
    """Palm swinging along the avatar's y by +-``amplitude``: on an arc of radius ``arc_radius``
    about a pivot below the centre (the forearm pivoting at the elbow), or on a straight line
    when ``arc_radius == 0``."""
    env = fade_in(t, ramp)
    s = np.sin(2 * np.pi * t / period) * env
    p = np.broadcast_to(center, (len(t), 3)).copy()
    if arc_radius > 0.0:
        phi = np.arcsin(amplitude / arc_radius) * s
        p[:, 1] += arc_radius * np.sin(phi)
        p[:, 2] += arc_radius * (np.cos(phi) - 1.0)
    else:
        p[:, 1] += amplitude * s
    return p


def axes_path(t: np.ndarray, center: np.ndarray, R_avatar_base: np.ndarray, amplitude: float,
              duration: float, cycles: int, order: list[str]) -> np.ndarray:
    """Palm oscillating along each robot-base axis in turn, ``cycles`` times per axis, with a
    minimum-jerk time warp so every axis starts and ends at rest at the centre."""
    k = np.floor(t / duration).astype(int)
    u = t / duration - k
    axis = np.array([AXIS_INDEX[a] for a in order])[np.mod(k, len(order))]
    s = amplitude * np.sin(2 * np.pi * cycles * min_jerk(u))
    direction = R_avatar_base[:, axis].T  # (N, 3): robot axis in the avatar frame
    return center + s[:, None] * direction


def point_cycle(t: np.ndarray, c: PointMotion) -> tuple[np.ndarray, np.ndarray]:
    """The pointing gesture's ``(index k, time tau within it)`` at times ``t`` (s): each
    gesture is ``rest``, ``move`` (raise), ``hold``, ``move`` (lower)."""
    cycle = c.rest + 2 * c.move + c.hold
    k = np.floor(np.asarray(t, float) / cycle).astype(int)
    return k, np.asarray(t, float) - k * cycle


def point_path(t: np.ndarray, p_shoulder: np.ndarray, arm: float, c: PointMotion) -> np.ndarray:
    """Schmidt-style pointing: per gesture rest (hanging), raise, hold, lower; the shoulder-palm
    direction moves on a great circle, the distance linearly, both minimum-jerk in time."""
    side = -1.0 if c.hand == "right" else 1.0
    k, tau = point_cycle(t, c)
    s = np.where(tau < c.rest + c.move, min_jerk((tau - c.rest) / c.move),
                 1.0 - min_jerk((tau - c.rest - c.move - c.hold) / c.move))
    dir_rest = np.array([0.1, 0.08 * side, -1.0])
    dir_rest /= np.linalg.norm(dir_rest)
    d_rest = 0.93 * arm
    azimuth = {"side": np.pi / 2, "angle": c.angle}
    p = np.empty((len(t), 3))
    gesture = np.mod(k, len(c.gestures))
    for i, name in enumerate(c.gestures):
        sel = gesture == i
        if not np.any(sel):
            continue
        a, e = azimuth[name], c.elevation
        d_point = np.array([np.cos(e) * np.cos(a), side * np.cos(e) * np.sin(a), np.sin(e)])
        direction = slerp_vectors(dir_rest, d_point, s[sel])
        dist = d_rest + (c.reach * arm - d_rest) * s[sel]
        p[sel] = p_shoulder + dist[:, None] * direction
    return p


def figure8_path(t: np.ndarray, center: np.ndarray, width: float, height: float,
                 period: float, ramp: float) -> np.ndarray:
    """Gerono lemniscate in the frontal plane: y = W/2 sin(wt), z = H sin(wt) cos(wt)."""
    wt = 2 * np.pi * t / period
    env = fade_in(t, ramp)
    p = np.broadcast_to(center, (len(t), 3)).copy()
    p[:, 1] += env * 0.5 * width * np.sin(wt)
    p[:, 2] += env * height * np.sin(wt) * np.cos(wt)
    return p


def head_sweep_path(t: np.ndarray, head0: np.ndarray, amplitude: float, period: float,
                    ramp: float) -> np.ndarray:
    """Head centre moving along the avatar's y: ``amplitude sin(2 pi t / period)``."""
    p = np.broadcast_to(head0, (len(t), 3)).copy()
    p[:, 1] += amplitude * np.sin(2 * np.pi * t / period) * fade_in(t, ramp)
    return p


# ---- motions ----------------------------------------------------------------------------------
class TargetMotion:
    """A motion given by target paths (functions of time), solved per sample by IK."""

    sample_rate = PRIMITIVE_RATE

    def __init__(self, g: AvatarGeometry, paths: dict[str, Path], head_lean: float = 0.25,
                 palm_dir: np.ndarray | None = None, joint_paths: dict[str, Path] | None = None):
        self.geometry = g
        self.paths = paths
        """``right_hand`` / ``left_hand`` / ``head`` -> path (avatar frame)."""
        self.joint_paths = joint_paths or {}
        """joint -> path of its value (slides/hinges) or rotation vector (balls)."""
        self.head_lean = head_lean
        self.palm_dir = palm_dir

    def _solve(self, t: np.ndarray):
        t = np.atleast_1d(np.asarray(t, float))
        targets = PoseTargets(**{k: f(t) for k, f in self.paths.items()},
                              joints={j: f(t) for j, f in self.joint_paths.items()})
        return solve_pose(len(t), targets, self.geometry, self.head_lean, self.palm_dir)

    def sample(self, t: np.ndarray) -> np.ndarray:
        return self._solve(t)[0]

    def diagnostics(self, t: np.ndarray) -> dict[str, float]:
        q, ik = self._solve(t)
        return pose_diagnostics(q, ik, self.geometry)


def _hand_key(hand: str) -> str:
    return f"{hand}_hand"


def _constant(p) -> Path:
    p = np.asarray(p, float)
    return lambda t: np.broadcast_to(p, (len(t), 3))


def _trembling(p0: np.ndarray, freqs: np.ndarray, phases: np.ndarray, amp: float) -> Path:
    return lambda t: p0 + tremor(t, freqs, phases, amp)


def make_static(c: StaticMotion, ctx: MotionContext) -> TargetMotion:
    paths: dict[str, Path] = {}
    for key in ("right_hand", "left_hand"):
        p = getattr(c, key)
        if p is None:
            continue
        if c.tremor > 0.0:
            comps = tremor_components(ctx.rng, c.tremor, c.tremor_frequency)
            paths[key] = _trembling(np.asarray(p, float), *comps)
        else:
            paths[key] = _constant(p)
    return TargetMotion(ctx.geometry, paths, palm_dir=ctx.palm_direction)


def make_wave(c: WaveMotion, ctx: MotionContext) -> TargetMotion:
    center = np.asarray(c.center or mirror(RIGHT_HAND_WAVE, c.hand), float)

    def path(t):
        return wave_path(t, center, c.amplitude, c.period, c.arc_radius, c.ramp)

    return TargetMotion(ctx.geometry, {_hand_key(c.hand): path}, palm_dir=ctx.palm_direction)


def make_axes(c: AxesMotion, ctx: MotionContext) -> TargetMotion:
    center = np.asarray(c.center or mirror(RIGHT_HAND_FRONT, c.hand), float)
    R = ctx.R_avatar_base.copy()

    def path(t):
        return axes_path(t, center, R, c.amplitude, c.duration_per_axis, c.cycles, c.order)

    return TargetMotion(ctx.geometry, {_hand_key(c.hand): path}, palm_dir=ctx.palm_direction)


def make_point(c: PointMotion, ctx: MotionContext) -> TargetMotion:
    g = ctx.geometry
    side = "r" if c.hand == "right" else "l"
    p_shoulder = g.pelvis + g.chest + g.shoulder[side]
    arm = sum(arm_lengths(g))

    def path(t):
        return point_path(t, p_shoulder, arm, c)

    return TargetMotion(g, {_hand_key(c.hand): path}, palm_dir=ctx.palm_direction)


def make_figure8(c: Figure8Motion, ctx: MotionContext) -> TargetMotion:
    center = np.asarray(c.center or mirror(RIGHT_HAND_FIGURE8, c.hand), float)

    def path(t):
        return figure8_path(t, center, c.width, c.height, c.period, c.ramp)

    return TargetMotion(ctx.geometry, {_hand_key(c.hand): path}, palm_dir=ctx.palm_direction)


def make_head_sweep(c: HeadSweepMotion, ctx: MotionContext) -> TargetMotion:
    head0 = ctx.geometry.head_zero

    def path(t):
        return head_sweep_path(t, head0, c.amplitude, c.period, c.ramp)

    return TargetMotion(ctx.geometry, {"head": path}, head_lean=c.lean)
