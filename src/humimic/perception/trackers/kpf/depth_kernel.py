"""The kept wrist range (``KpfConfig.keep_range_share``) compiled: one loop over the particles
doing what :func:`~humimic.perception.trackers.kpf.depth.keep_wrist_range` does with numpy
(the wrists' camera ranges, :func:`~humimic.perception.trackers.kpf.depth.reachable_range_change`,
:func:`~humimic.perception.trackers.kpf.depth.wrist_depth_move` with
:func:`~humimic.maths.rotations.rotation_between` and
:func:`~humimic.bodymodel.avatar.shoulder_angles`), which stays as its reference (tested
against each other to ~1e-12). numpy's per-call overhead over ~150 small-array calls per arm
was a quarter of a (150, 2) frame of Table 1's ``kpf``.

The shoulder angles are the intrinsic y-x-z Euler angles of ``R_torso_upper`` in closed form
(``Ry(a) Rx(b) Rz(g)``: ``b = atan2(-M12, hypot(M10, M11))``, ``a = atan2(M02, M22)``,
``g = atan2(M10, M11)``; at ``cos b`` = 0, ``g = 0`` and ``a = atan2(-M20, M00)``, as scipy
sets the third angle to 0 there), then :func:`~humimic.bodymodel.avatar.shoulder_angles`' choice
between the two decompositions.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.bodymodel.geometry_kernels import axis_rotation_into, mat3_mul
from humimic.maths.jit import njit

#: ``cos b`` below this is gimbal lock (the third angle set to 0).
GIMBAL_EPS = 1e-12
#: :func:`~humimic.perception.trackers.kpf.depth.reachable_range_change`'s default margin.
REACH_MARGIN = 1e-3


@njit(inline="always")
def _wrap(a):
    """``(a + pi) mod 2 pi - pi`` (numpy's ``%``: the divisor's sign)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@njit(inline="always")
def _rotation_between(a, b, out):
    """``out (3, 3)``: :func:`~humimic.maths.rotations.rotation_between` of one pair."""
    na = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    nb = math.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
    a0, a1, a2 = a[0] / na, a[1] / na, a[2] / na
    b0, b1, b2 = b[0] / nb, b[1] / nb, b[2] / nb
    v0, v1, v2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    c = a0 * b0 + a1 * b1 + a2 * b2
    s2 = v0 * v0 + v1 * v1 + v2 * v2
    if s2 <= 1e-24 and c < 0.0:         # a half turn about an axis perpendicular to a
        k = 0
        if abs(a1) < abs(a0):
            k = 1
        if abs(a2) < min(abs(a0), abs(a1)):
            k = 2
        e = np.zeros(3)
        e[k] = 1.0
        p0, p1, p2 = a1 * e[2] - a2 * e[1], a2 * e[0] - a0 * e[2], a0 * e[1] - a1 * e[0]
        n = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        p = (p0 / n, p1 / n, p2 / n)
        for r in range(3):
            for m in range(3):
                out[r, m] = 2.0 * p[r] * p[m] - (1.0 if r == m else 0.0)
        return
    f = (1.0 - c) / s2 if s2 > 1e-24 else 0.5
    v = (v0, v1, v2)
    # I + K + f K^2 with K the cross-product matrix of v: K^2 = v v^T - |v|^2 I
    out[0, 0], out[0, 1], out[0, 2] = 1.0, -v2, v1
    out[1, 0], out[1, 1], out[1, 2] = v2, 1.0, -v0
    out[2, 0], out[2, 1], out[2, 2] = -v1, v0, 1.0
    for r in range(3):
        for m in range(3):
            out[r, m] += f * (v[r] * v[m] - (s2 if r == m else 0.0))


@njit(inline="always")
def _shoulder_angles(M, signs, alo, ahi, out):
    """``out (3,)``: :func:`~humimic.bodymodel.avatar.shoulder_angles` of one rotation
    ``M = R_torso_upper`` (module doc), arm signs ``signs (3,)`` and limits ``alo``, ``ahi``."""
    cb = math.sqrt(M[1, 0] * M[1, 0] + M[1, 1] * M[1, 1])
    b = math.atan2(-M[1, 2], cb)
    if cb > GIMBAL_EPS:
        a, g = math.atan2(M[0, 2], M[2, 2]), math.atan2(M[1, 0], M[1, 1])
    else:
        a, g = math.atan2(-M[2, 0], M[0, 0]), 0.0
    e1, e2 = (a, b, g), (a + np.pi, np.pi - b, g + np.pi)
    x1, x2, n1, n2 = 0.0, 0.0, 0.0, 0.0
    f, s = np.empty(3), np.empty(3)
    for k in range(3):
        f[k], s[k] = _wrap(e1[k] * signs[k]), _wrap(e2[k] * signs[k])
        x1 += max(alo[k] - f[k], 0.0) + max(f[k] - ahi[k], 0.0)
        x2 += max(alo[k] - s[k], 0.0) + max(s[k] - ahi[k], 0.0)
        n1 += f[k] * f[k]
        n2 += s[k] * s[k]
    second = n2 < n1 if abs(x1 - x2) <= 1e-9 else x2 < x1
    for k in range(3):
        out[k] = s[k] if second else f[k]


@njit
def keep_range_rows(q, rows, p, R, p_ref, c, seg, j, lu, lf, clip, elbow, signs, alo, ahi,
                    lo, hi, out):
    """``out[rows]``: arm ``j`` (its DOFs' offset in the state) of states ``q (N, 14)`` re-solved
    so its wrist lies at the camera (centre ``c``) range of the reference poses' (``p_ref``,
    ``(N, S, 3)`` segment origins) on its own ray, the outer reach clipped with ``clip``
    (:func:`~humimic.perception.trackers.kpf.depth.keep_wrist_range`); ``p``, ``R`` ``q``'s
    segment origins and frames; ``seg``: the segments of the shoulder, wrist, upper arm and
    torso; ``elbow``: the elbow's (axis, sign); ``signs``, ``alo``, ``ahi`` the shoulder's
    axis signs and (default) limits, ``lo``, ``hi`` the state's. Rows the move cannot reach
    are left as they are in ``out``."""
    iS, iW, iU, iT = seg[0], seg[1], seg[2], seg[3]
    reach = (1.0 - REACH_MARGIN) * (lu + lf)
    E, A, Rr, Rn, M = (np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)),
                       np.empty((3, 3)), np.empty((3, 3)))
    d, dl, ang, new = np.empty(3), np.empty(3), np.empty(3), np.empty(q.shape[1])
    for i in rows:
        S, W, Wr = p[i, iS], p[i, iW], p_ref[i, iW]
        u0, u1, u2 = W[0] - c[0], W[1] - c[1], W[2] - c[2]
        rw = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        delta = math.sqrt((Wr[0] - c[0]) ** 2 + (Wr[1] - c[1]) ** 2 + (Wr[2] - c[2]) ** 2) - rw
        u0, u1, u2 = u0 / rw, u1 / rw, u2 / rw
        w0, w1, w2 = W[0] - S[0], W[1] - S[1], W[2] - S[2]
        if clip:
            bb = u0 * w0 + u1 * w1 + u2 * w2
            disc = bb * bb - ((w0 * w0 + w1 * w1 + w2 * w2) - reach * reach)
            sq = math.sqrt(max(disc, 0.0))
            delta = min(max(delta, -bb - sq), -bb + sq) if disc > 0.0 else 0.0
        d[0], d[1], d[2] = w0 + delta * u0, w1 + delta * u1, w2 + delta * u2
        r = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        if not (abs(lu - lf) + 1e-6 < r < lu + lf - 1e-6):
            continue
        eb = math.acos(min(max((r * r - lu * lu - lf * lf) / (2 * lu * lf), -1.0), 1.0))
        axis_rotation_into(E, elbow[0], elbow[1] * eb)
        for k in range(3):        # the shoulder -> wrist vector for eb, in the upper arm's
            dl[k] = (-lu if k == 2 else 0.0) - lf * E[k, 2]
        for k in range(3):        # ... and in the reference frame
            ang[k] = R[i, iU, k, 0] * dl[0] + R[i, iU, k, 1] * dl[1] + R[i, iU, k, 2] * dl[2]
        _rotation_between(ang, d, Rr)
        mat3_mul(Rr, R[i, iU], Rn)
        for r0 in range(3):
            for m in range(3):
                A[r0, m] = R[i, iT, m, r0]          # R_ref_torso transposed
        mat3_mul(A, Rn, M)
        _shoulder_angles(M, signs, alo, ahi, ang)
        ok = True
        for k in range(q.shape[1]):
            new[k] = out[i, k]      # (another arm may have moved already)
        new[j], new[j + 1], new[j + 2], new[j + 3] = ang[0], ang[1], ang[2], eb
        for k in range(q.shape[1]):
            if not (np.isfinite(new[k]) and lo[k] <= new[k] <= hi[k]):
                ok = False
        if ok:
            for k in range(q.shape[1]):
                out[i, k] = new[k]


def kept_range_rows(body, q: np.ndarray, pose, pose_ref, rows: np.ndarray, side: str,
                    c_ref: np.ndarray, clip: bool, out: np.ndarray) -> None:
    """:func:`keep_range_rows` of arm ``side`` (``R``, ``L``) for ``rows`` of ``q``, the
    body's forward kinematics ``pose`` (of ``q``) and ``pose_ref`` (of the references) given,
    into ``out``."""
    from humimic.bodymodel.avatar import _arm_limits
    from humimic.bodymodel.kinematics import ARM_AXES, JOINT_SEGMENT, SEGMENTS
    from humimic.perception.trackers.kpf.depth import SIDES

    prefix, j = SIDES[side]
    seg = np.array([SEGMENTS.index(JOINT_SEGMENT[f"{prefix}_shoulder"]),
                    SEGMENTS.index(JOINT_SEGMENT[f"{prefix}_wrist"]),
                    SEGMENTS.index(f"{prefix}_upper_arm"), SEGMENTS.index("torso")], np.intp)
    axis, sign = ARM_AXES[side][3]
    arm = _arm_limits(side)
    lim = body.free_limits
    sk = body.skeleton
    keep_range_rows(q, np.asarray(rows, np.intp), pose.p, pose.R, pose_ref.p,
                    np.asarray(c_ref, float), seg, j, float(sk.upper_arm), float(sk.forearm),
                    bool(clip), (axis, float(sign)),
                    np.array([s for _, s in ARM_AXES[side][:3]], float), arm.lower, arm.upper,
                    lim.lower, lim.upper, out)
