"""What Schmidt et al.'s cues read of a projected body model, compiled: the kernel particle
filter's per-evaluation projection.

:func:`limb_view` gives the fields of :func:`~humimic.bodymodel.projection.project`'s
:class:`~humimic.bodymodel.projection.BodyView` that the limb features and the skin ellipses
use -- validity, the cones' contour generators and image axes, the ellipsoids' image ellipses
in pixels (``BodyView.ellipses_px``) -- from one compiled loop over particles and parts (the
part frames, the cones' generator angles and ends in closed form as
:mod:`~humimic.bodymodel.cones` states them, the ellipsoids' image ellipses and the rotations
from the shared scalar kernels of :mod:`~humimic.bodymodel.geometry_kernels`; ``project`` is
the reference it is tested against). numpy's per-call overhead on ``(N, parts)`` arrays dominated
``project`` at the paper's 150 particles. Pixels come from
:meth:`~humimic.sensors.camera_model.Intrinsics.distort` (the one projection implementation),
applied to the kernel's normalised coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.bodymodel.geometry_kernels import ellipse_axes, ellipsoid_ellipse
from humimic.bodymodel.model import BodyModel, Pose
from humimic.bodymodel.projection import Z_MIN
from humimic.maths.jit import njit
from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True, eq=False)
class LimbView:
    """The limb-feature and ellipse fields of a :class:`~humimic.bodymodel.BodyView`."""

    valid: np.ndarray
    """(N, P) bool: the part lies wholly in front of the camera."""
    cone_idx: np.ndarray
    ellipsoid_idx: np.ndarray
    generators: np.ndarray
    """(N, Pc) bool: the cone's contour generators exist."""
    sides_uv: np.ndarray
    """(N, Pc, 2 sides, 2 ends, 2) the contour generators in pixels (NaN where invalid)."""
    axis_uv: np.ndarray
    """(N, Pc, 2, 2) the cones' axis ends in pixels."""
    ellipses: tuple[np.ndarray, np.ndarray, np.ndarray]
    """The ellipsoids' image ellipses in pixels: centres ``(N, Pe, 2)``, semi-axes
    ``(N, Pe, 2)`` (major, minor), the major axis' angle ``(N, Pe)``."""

    def ellipses_px(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.ellipses


@njit
def _view_kernel(R_seg, p_seg, segment, p_sp, R_sp, aligned, T, ci, shape, ei, semi, K,
                 z_min, sides, axis):
    """Fills ``sides (n, nc, 2, 2, 2)``, ``axis (n, nc, 2, 2)`` (normalised x, y)."""
    n, P, nc, ne = R_seg.shape[0], len(segment), len(ci), len(ei)
    valid = np.zeros((n, P), np.bool_)
    exists = np.zeros((n, nc), np.bool_)
    ell = np.empty((n, ne, 5))                   # centre u, v (px), major, minor, angle
    R, Rr, t, tc = np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3)
    for s in range(n):
        for i in range(P):
            g = segment[i]
            for r in range(3):                   # the part's frame in the camera
                t[r] = p_seg[s, g, r] + (R_seg[s, g, r, 0] * p_sp[i, 0]
                                         + R_seg[s, g, r, 1] * p_sp[i, 1]
                                         + R_seg[s, g, r, 2] * p_sp[i, 2])
            for r in range(3):
                for m in range(3):
                    if aligned:
                        Rr[r, m] = R_seg[s, g, r, m]
                    else:
                        Rr[r, m] = (R_seg[s, g, r, 0] * R_sp[i, 0, m]
                                    + R_seg[s, g, r, 1] * R_sp[i, 1, m]
                                    + R_seg[s, g, r, 2] * R_sp[i, 2, m])
            for r in range(3):
                tc[r] = T[r, 0] * t[0] + T[r, 1] * t[1] + T[r, 2] * t[2] + T[r, 3]
                for m in range(3):
                    R[r, m] = T[r, 0] * Rr[0, m] + T[r, 1] * Rr[1, m] + T[r, 2] * Rr[2, m]
            for r in range(3):
                t[r] = tc[r]
            for j in range(nc):
                if ci[j] == i:
                    _cone(s, j, R, t, shape[j], z_min, valid[s], i, exists, sides, axis)
            for j in range(ne):
                if ei[j] == i:
                    _ellipsoid(s, j, R, t, semi[j], z_min, valid[s], i, K, ell)
    return valid, exists, ell


@njit
def _cone(s, j, R, t, shape, z_min, valid, i, exists, sides, axis):
    """``cones.generator_angles``, ``in_front``, ``rim_points`` at the generators' ends (the
    ends' cosines and sines by the angle-sum formulas: ``phi_c = atan2(B, A)``,
    ``delta = acos(C / r)``)."""
    a, b, L, k = shape[0], shape[1], shape[2], shape[3]
    c0 = -(t[0] * R[0, 0] + t[1] * R[1, 0] + t[2] * R[2, 0])     # camera centre, local
    c1 = -(t[0] * R[0, 1] + t[1] * R[1, 1] + t[2] * R[2, 1])
    c2 = -(t[0] * R[0, 2] + t[1] * R[1, 2] + t[2] * R[2, 2])
    A, B, C = L * b * c0, L * a * c1, a * b * (L + (k - 1.0) * c2)
    r = np.hypot(A, B)
    ratio = C / r
    exists[s, j] = abs(ratio) < 1.0
    cp, sp = (A / r, B / r) if r > 0.0 else (1.0, 0.0)
    cd = 1.0 if np.isnan(ratio) else min(max(ratio, -1.0), 1.0)
    sd = np.sqrt((1.0 - cd) * (1.0 + cd))
    reach0 = np.hypot(a * R[2, 0], b * R[2, 1])
    ok = (t[2] - reach0 > z_min) and (t[2] + L * R[2, 2] - k * reach0 > z_min)
    valid[i] = ok
    for side in range(2):
        sg = 1.0 if side == 0 else -1.0              # phi_c + delta, phi_c - delta
        cs, sn = cp * cd - sg * sp * sd, sp * cd + sg * cp * sd
        for rim in range(2):
            scale = 1.0 + (k - 1.0) * rim
            lx, ly, lz = a * scale * cs, b * scale * sn, L * rim
            X = t[0] + R[0, 0] * lx + R[0, 1] * ly + R[0, 2] * lz
            Y = t[1] + R[1, 0] * lx + R[1, 1] * ly + R[1, 2] * lz
            Z = t[2] + R[2, 0] * lx + R[2, 1] * ly + R[2, 2] * lz
            inv_z = 1.0 / Z if ok else np.nan
            sides[s, j, side, rim, 0] = X * inv_z
            sides[s, j, side, rim, 1] = Y * inv_z
    for end in range(2):                         # axis: base and top rim centres
        X, Y, Z = t[0] + R[0, 2] * L * end, t[1] + R[1, 2] * L * end, t[2] + R[2, 2] * L * end
        axis[s, j, end, 0] = X / Z
        axis[s, j, end, 1] = Y / Z


@njit
def _ellipsoid(s, j, R, t, semi, z_min, valid, i, K, ell):
    """:func:`~humimic.bodymodel.geometry_kernels.ellipsoid_ellipse`, then
    ``BodyView.ellipses_px`` (``K``'s affine part) and ``conics.ellipse_axes``."""
    cx, cy, m00, m01, m11, ok = ellipsoid_ellipse(R, t, semi, z_min)
    valid[i] = ok
    # pixels: centre A c + (c_u, c_v), shape A M A^T with A = K[:2, :2]
    ell[s, j, 0] = K[0, 0] * cx + K[0, 1] * cy + K[0, 2]
    ell[s, j, 1] = K[1, 0] * cx + K[1, 1] * cy + K[1, 2]
    am00, am01 = K[0, 0] * m00 + K[0, 1] * m01, K[0, 0] * m01 + K[0, 1] * m11
    am10, am11 = K[1, 0] * m00 + K[1, 1] * m01, K[1, 0] * m01 + K[1, 1] * m11
    p = am00 * K[0, 0] + am01 * K[0, 1]
    q = am00 * K[1, 0] + am01 * K[1, 1]
    w = am10 * K[1, 0] + am11 * K[1, 1]
    ell[s, j, 2], ell[s, j, 3], ell[s, j, 4] = ellipse_axes(p, q, w)


def limb_view(body: BodyModel, pose: Pose, intr: Intrinsics, T_cam_ref: np.ndarray
              ) -> LimbView:
    """The limb-feature and ellipse fields of ``project(body, pose, intr, T_cam_ref)``."""
    lay = body.layout
    K = np.asarray(intr.K, float)
    n, nc = len(pose.R), len(lay.cone_idx)
    xy = np.empty(n * nc * 12)                  # sides then axis ends: one distort pass
    cut = n * nc * 8
    valid, exists, ell = _view_kernel(
        np.ascontiguousarray(pose.R, float), np.ascontiguousarray(pose.p, float),
        np.ascontiguousarray(lay.segment, np.intp), np.ascontiguousarray(lay.p_seg_part, float),
        np.ascontiguousarray(lay.R_seg_part, float), bool(lay.aligned),
        np.ascontiguousarray(T_cam_ref, float), np.ascontiguousarray(lay.cone_idx, np.intp),
        np.ascontiguousarray(lay.cone_shape, float),
        np.ascontiguousarray(lay.ellipsoid_idx, np.intp),
        np.ascontiguousarray(lay.semi_axes, float), K, float(Z_MIN),
        xy[:cut].reshape(n, nc, 2, 2, 2), xy[cut:].reshape(n, nc, 2, 2))
    uv = np.empty_like(xy)
    uv[0::2], uv[1::2] = intr.distort(xy[0::2], xy[1::2])
    return LimbView(valid, lay.cone_idx, lay.ellipsoid_idx, exists,
                    uv[:cut].reshape(n, nc, 2, 2, 2), uv[cut:].reshape(n, nc, 2, 2),
                    (ell[..., :2], ell[..., 2:4], ell[..., 4]))
