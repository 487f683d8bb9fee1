"""The body model's geometry for one part at a time, compiled (:mod:`humimic.maths.jit`): the
scalar forms that the trackers' per-particle kernels call, so each concept exists once in
compiled form. The vectorised numpy functions stay the public implementations and the
references these are tested against:

* :func:`axis_rotation_into`, :func:`ypr_into` -- :func:`~humimic.bodymodel.kinematics.
  axis_rotation` and :func:`~humimic.bodymodel.kinematics.ypr_matrix` of one angle;
  :func:`mat3_mul` a 3x3 product.
* :func:`ellipsoid_ellipse` -- Menezes eqs. 14-15: :func:`~humimic.bodymodel.conics.
  ellipsoid_quadric`, :func:`~humimic.bodymodel.conics.quadric_to_conic` and
  :func:`~humimic.bodymodel.conics.conic_to_ellipse` of one ellipsoid, with the
  "wholly in front of the camera" test of :mod:`~humimic.bodymodel.projection`.
* :func:`ellipse_axes` -- :func:`~humimic.bodymodel.conics.ellipse_axes` of one shape matrix.

Each is inlined into its caller (``inline="always"``, numba's IR-level inlining): called as a
separate compiled function from a kernel in another file, the ellipse alone made
:mod:`~humimic.bodymodel.limb_view`'s kernel ~5 % slower (CPU time, 150 particles).
"""

from __future__ import annotations

import math

import numpy as np

from humimic.maths.jit import njit


@njit(inline="always")
def axis_rotation_into(out, axis, angle):
    """``out (3, 3)`` = the rotation by ``angle`` (rad) about the x/y/z axis ``0/1/2``
    (:func:`~humimic.bodymodel.kinematics.axis_rotation`)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    for r in range(3):
        for m in range(3):
            out[r, m] = 0.0
    out[axis, axis] = 1.0
    out[i, i] = c
    out[j, j] = c
    out[j, i] = s
    out[i, j] = -s


@njit(inline="always")
def ypr_into(out, yaw, pitch, roll):
    """``out (3, 3) = Rz(yaw) Ry(pitch) Rx(roll)`` (:func:`~humimic.bodymodel.kinematics.
    ypr_matrix`)."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    out[0, 0], out[0, 1], out[0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    out[1, 0], out[1, 1], out[1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    out[2, 0], out[2, 1], out[2, 2] = -sp, cp * sr, cp * cr


@njit(inline="always")
def mat3_mul(A, B, out):
    """``out = A B`` (3x3; ``out`` must not alias ``A`` or ``B``)."""
    for r in range(3):
        for m in range(3):
            out[r, m] = A[r, 0] * B[0, m] + A[r, 1] * B[1, m] + A[r, 2] * B[2, m]


@njit(inline="always")
def ellipsoid_ellipse(R, t, semi, z_min):
    """The image ellipse in the normalised camera of the ellipsoid with semi-axes ``semi (3)``
    along the columns of ``R (3, 3)``, centred at ``t (3)`` (camera frame): ``conics.
    ellipsoid_quadric`` (``A = R S^-2 R^T``, ``b = -A t``, ``c = t^T A t - 1``), the conic
    ``C = c A - b b^T`` (Menezes eq. 15) and ``conics.conic_to_ellipse``.

    Returns the centre ``cx, cy``, the shape matrix ``m00, m01, m11`` (``(x - c)^T M^-1
    (x - c) = 1``) and ``ok``: a real ellipse, the camera outside the ellipsoid and the
    ellipsoid wholly beyond ``z = z_min`` (its nearest point's depth ``t_z - reach_z``)."""
    i0, i1, i2 = 1.0 / semi[0] ** 2, 1.0 / semi[1] ** 2, 1.0 / semi[2] ** 2
    # A = R S^-2 R^T (symmetric)
    a00 = R[0, 0] * i0 * R[0, 0] + R[0, 1] * i1 * R[0, 1] + R[0, 2] * i2 * R[0, 2]
    a01 = R[0, 0] * i0 * R[1, 0] + R[0, 1] * i1 * R[1, 1] + R[0, 2] * i2 * R[1, 2]
    a02 = R[0, 0] * i0 * R[2, 0] + R[0, 1] * i1 * R[2, 1] + R[0, 2] * i2 * R[2, 2]
    a11 = R[1, 0] * i0 * R[1, 0] + R[1, 1] * i1 * R[1, 1] + R[1, 2] * i2 * R[1, 2]
    a12 = R[1, 0] * i0 * R[2, 0] + R[1, 1] * i1 * R[2, 1] + R[1, 2] * i2 * R[2, 2]
    a22 = R[2, 0] * i0 * R[2, 0] + R[2, 1] * i1 * R[2, 1] + R[2, 2] * i2 * R[2, 2]
    b0 = a00 * t[0] + a01 * t[1] + a02 * t[2]    # A t (the quadric's b = -A t)
    b1 = a01 * t[0] + a11 * t[1] + a12 * t[2]
    b2 = a02 * t[0] + a12 * t[1] + a22 * t[2]
    c = t[0] * b0 + t[1] * b1 + t[2] * b2 - 1.0
    # the conic c A - b b^T, then its ellipse (conic_to_ellipse)      # Menezes eq. 15
    a, b, d = c * a00 - b0 * b0, c * a01 - b0 * b1, c * a11 - b1 * b1
    ux, uy, c33 = c * a02 - b0 * b2, c * a12 - b1 * b2, c * a22 - b2 * b2
    det = a * d - b * b
    cx, cy = (b * uy - d * ux) / det, (b * ux - a * uy) / det
    kk = (cx * (a * cx + b * cy) + cy * (b * cx + d * cy) - c33) / det
    m00, m01, m11 = kk * d, -kk * b, kk * a
    finite = np.isfinite(m00) and np.isfinite(m01) and np.isfinite(m11)
    reach_z = np.sqrt((R[2, 0] * semi[0]) ** 2 + (R[2, 1] * semi[1]) ** 2
                      + (R[2, 2] * semi[2]) ** 2)
    ok = det > 0 and m00 > 0 and finite and c > 0.0 and t[2] - reach_z > z_min
    return cx, cy, m00, m01, m11, ok


@njit(inline="always")
def ellipse_axes(m00, m01, m11):
    """Semi-major, semi-minor axis and the major axis' angle (rad, from +x towards +y) of the
    ellipse with shape matrix ``[[m00, m01], [m01, m11]]`` (:func:`~humimic.bodymodel.conics.
    ellipse_axes`)."""
    half_tr, half_diff = (m00 + m11) / 2.0, (m00 - m11) / 2.0
    r = np.hypot(half_diff, m01)
    return (np.sqrt(max(half_tr + r, 0.0)), np.sqrt(max(half_tr - r, 0.0)),
            0.5 * np.arctan2(2.0 * m01, m00 - m11))
