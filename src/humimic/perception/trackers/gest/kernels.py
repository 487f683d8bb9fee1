"""GEST's per-particle loops, compiled (:mod:`humimic.maths.jit`): the projection of the hand
ellipsoids into the cameras (Menezes eq. 15) with their contour points and colour patches, the
points the shape and skin cues sample, the stereo cue, and the flipped sum of the particles'
rotations behind the published orientation. Each does in one pass over the particles what a
few dozen numpy array operations do (their temporaries and call overhead are most of the cost
at 100 particles); those numpy functions (:func:`.likelihood.project_views_numpy`,
:func:`.likelihood.blob_pair_log_likelihood_numpy`, :func:`.ellipsoid.mean_orientation_numpy`,
the cues' own samplers) stay as the references the tests compare them with.

The geometry is not restated here: the ellipsoid's image ellipse, the rotations and the lens
model are the shared scalar kernels of :mod:`humimic.bodymodel.geometry_kernels` and
:mod:`humimic.sensors.camera_kernels` (:mod:`humimic.maths.jit` keys the on-disk cache on
every kernel module, so an edit to a callee in another file recompiles its callers).
"""

from __future__ import annotations

import math

import numpy as np

from humimic.bodymodel.geometry_kernels import ellipse_axes, ellipsoid_ellipse, mat3_mul, ypr_into
from humimic.bodymodel.projection import Z_MIN
from humimic.maths.jit import njit
from humimic.sensors.camera_kernels import distort_point

#: The off-image sentinel of :mod:`.likelihood` (contour points and centres of invalid parts).
OFF_IMAGE = -1.0e6
_SQRT2 = math.sqrt(2.0)


def camera_arrays(views) -> tuple[np.ndarray, np.ndarray]:
    """``T_cam_base (V, 4, 4)`` and intrinsics ``(V, 6)`` = ``fx, fy, cx, cy, k1, k2`` of
    ``views`` (anything with ``T_cam_base`` and ``intrinsics``), as :func:`project_states`
    reads them."""
    T = np.stack([np.asarray(v.T_cam_base, float) for v in views])
    K = np.array([[v.intrinsics.fx, v.intrinsics.fy, v.intrinsics.cx, v.intrinsics.cy,
                   v.intrinsics.k1, v.intrinsics.k2] for v in views], float)
    return T, K


@njit
def project_states(states, T, K, cos, sin, n_image):
    """Menezes eq. 15 for hand states ``(N, 9)`` (centre, yaw pitch roll, semi-axes; base
    frame) in ``V`` cameras (``T (V, 4, 4)``, ``K (V, 6)``: :func:`camera_arrays`), and for the
    first ``n_image`` of them the contour points ``centre + L (cos psi, sin psi)`` (``L`` the
    Cholesky factor of the image ellipse's shape matrix; ``cos``, ``sin`` of the ``n`` steps of
    ``psi``), their outward unit normals ``L^-T (cos psi, sin psi)`` (normalised) and the colour
    patch ``(u, v, sqrt(2) fx minor)``.

    Returns ``contour (n_image, N, n, 2)``, ``normal`` (same), ``patch (n_image, N, 3)``,
    ``valid (V, N)`` (the ellipsoid wholly in front of the camera) and the ellipse centres
    ``(N, V, 2)`` (px); invalid parts as :func:`.likelihood.components_projection` gives them
    (contour and centre at the off-image sentinel, the normals of a unit circle)."""
    N, V, n = states.shape[0], T.shape[0], cos.shape[0]
    contour = np.empty((n_image, N, n, 2))
    normal = np.empty((n_image, N, n, 2))
    patch = np.empty((n_image, N, 3))
    valid = np.empty((V, N), np.bool_)
    centres = np.empty((N, V, 2))
    R = np.empty((3, 3))
    Rc = np.empty((3, 3))
    tv = np.empty(3)
    for i in range(N):
        ypr_into(R, states[i, 3], states[i, 4], states[i, 5])
        semi = states[i, 6:9]
        for v in range(V):
            # the ellipsoid's pose in the camera: Rc = T_R R, t = T_R centre + T_t
            mat3_mul(T[v], R, Rc)
            for r in range(3):
                tv[r] = (T[v, r, 0] * states[i, 0] + T[v, r, 1] * states[i, 1]
                         + T[v, r, 2] * states[i, 2] + T[v, r, 3])
            ex, ey, m00, m01, m11, ok = ellipsoid_ellipse(Rc, tv, semi, Z_MIN)  # Menezes eq. 15
            if not ok:
                ex, ey, m00, m01, m11 = 0.0, 0.0, 1.0, 0.0, 1.0
            valid[v, i] = ok
            u0, v0 = distort_point(K[v, 0], K[v, 1], K[v, 2], K[v, 3], K[v, 4], K[v, 5], ex, ey)
            centres[i, v, 0] = u0 if ok else OFF_IMAGE
            centres[i, v, 1] = v0 if ok else OFF_IMAGE
            if v >= n_image:
                continue
            l00 = math.sqrt(max(m00, 1e-300))
            l10 = m01 / l00
            l11 = math.sqrt(max(m11 - l10 * l10, 1e-300))
            i00, i11, i10 = 1.0 / l00, 1.0 / l11, l10 / (l00 * l11)
            for j in range(n):
                if ok:
                    uu, vv = distort_point(K[v, 0], K[v, 1], K[v, 2], K[v, 3], K[v, 4], K[v, 5],
                                           ex + l00 * cos[j], ey + l10 * cos[j] + l11 * sin[j])
                else:
                    uu, vv = OFF_IMAGE, OFF_IMAGE
                contour[v, i, j, 0], contour[v, i, j, 1] = uu, vv
                nx = cos[j] * i00 - i10 * sin[j]
                ny = sin[j] * i11
                h = 1.0 / math.sqrt(nx * nx + ny * ny)
                normal[v, i, j, 0], normal[v, i, j, 1] = nx * h, ny * h
            minor = ellipse_axes(m00, m01, m11)[1]
            patch[v, i, 0] = centres[i, v, 0]
            patch[v, i, 1] = centres[i, v, 1]
            patch[v, i, 2] = _SQRT2 * K[v, 0] * minor if ok else 1.0
    return contour, normal, patch, valid, centres


@njit
def _logaddexp(a, b):
    """``numpy.logaddexp`` for two floats (its branches: equal, either larger, NaN)."""
    if a == b:
        return a + math.log(2.0)
    d = a - b
    if d > 0.0:
        return a + math.log1p(math.exp(-d))
    if d <= 0.0:
        return b + math.log1p(math.exp(d))
    return a + b


@njit
def blob_pair_kernel(centres, pairs, sigma_px, log_outlier, floor):
    """:func:`.likelihood.blob_pair_log_likelihood` in one compiled pass over the particles'
    ellipse centres ``(N, V, 2)`` and the blob pairs ``(M, V, 2)`` (px): ``log(outlier + sum_j
    prod_v N(c_v; m_jv, sigma^2 I) / M)``, the outlier alone where that is not finite (the
    exponents floored at ``floor`` below each row's largest, as :func:`.proposal.logsumexp`)."""
    N, V = centres.shape[0], centres.shape[1]
    M = pairs.shape[0]
    out = np.full(N, log_outlier)
    if M == 0:
        return out
    c0 = -V * math.log(2.0 * math.pi * sigma_px ** 2)
    log_n = np.empty(M)
    for i in range(N):
        m = -np.inf
        for j in range(M):
            d2 = 0.0
            for v in range(V):
                for a in range(2):
                    e = centres[i, v, a] - pairs[j, v, a]
                    d2 += e * e
            log_n[j] = -0.5 * d2 / sigma_px ** 2 + c0
            m = max(m, log_n[j])
        if not np.isfinite(m):
            continue
        s = 0.0
        for j in range(M):
            s += math.exp(max(log_n[j] - m, floor))
        r = _logaddexp(log_outlier, math.log(s) + m - math.log(M))
        if np.isfinite(r):
            out[i] = r
    return out


@njit
def rim_maps(contour, normal, offset_px):
    """The points the shape and skin cues sample, as ``cv2.remap``'s two-channel float32 maps
    ``(3, N, n, 2)``: the contour points ``(N, n, 2)``, and the points ``offset_px`` inside and
    outside along the outward unit normals (``contour -/+ offset_px normal``, in float64 then
    rounded, as :func:`~humimic.perception.cues.skin.rim_skin_distance` forms them)."""
    N, n = contour.shape[0], contour.shape[1]
    out = np.empty((3, N, n, 2), np.float32)
    for i in range(N):
        for j in range(n):
            for a in range(2):
                c, step = contour[i, j, a], offset_px * normal[i, j, a]
                out[0, i, j, a] = c
                out[1, i, j, a] = c - step
                out[2, i, j, a] = c + step
    return out


#: The sign patterns ``d`` of the ellipsoid's proper symmetries, the half turns ``diag(d)``
#: about its axes (:data:`.ellipsoid.FLIPS`).
FLIP_SIGNS = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])


@njit
def flipped_rotation_sum(ypr, w):
    """``M = sum_n w_n R_n F_n``: the rotations ``Rz Ry Rx`` of ``ypr (N, 3)``, each turned by
    the half turn ``F_n`` of :data:`.ellipsoid.FLIPS` that brings it nearest the heaviest one's
    (``argmax w``; ``F = diag(d)`` flips the signs of ``R``'s columns, ``trace(R0^T R F) =
    sum_j d_j c_j`` with ``c_j`` the dot product of the two matrices' ``j``-th columns), in
    one compiled pass (:func:`.ellipsoid.mean_orientation_numpy` is the array form)."""
    n = ypr.shape[0]
    R = np.empty((n, 3, 3))
    for i in range(n):
        ypr_into(R[i], ypr[i, 0], ypr[i, 1], ypr[i, 2])
    i0 = np.argmax(w)
    M = np.zeros((3, 3))
    c = np.empty(3)
    for i in range(n):
        for j in range(3):
            c[j] = R[i0, 0, j] * R[i, 0, j] + R[i0, 1, j] * R[i, 1, j] + R[i0, 2, j] * R[i, 2, j]
        best, f = -np.inf, 0
        for k in range(4):
            score = FLIP_SIGNS[k, 0] * c[0] + FLIP_SIGNS[k, 1] * c[1] + FLIP_SIGNS[k, 2] * c[2]
            if score > best:
                best, f = score, k
        for j in range(3):
            wd = w[i] * FLIP_SIGNS[f, j]
            for r in range(3):
                M[r, j] += R[i, r, j] * wd
    return M
