"""Ellipsoids seen by a pinhole camera: quadric -> conic (Menezes et al. sec. 6.1.1).

Everything here works in the *normalised* camera (OpenCV axes: x right, y down, z forward;
image points ``x = (u, v, 1)`` with ``u = X/Z``, ``v = Y/Z``, no distortion) and broadcasts
over leading dimensions (particles, parts, points). A point quadric is kept as its blocks
``Q = [[A, b], [b^T, c]]`` (``X^T Q X = 0`` for homogeneous ``X``); a conic is a symmetric
3x3 ``C`` (``x^T C x = 0``), negative inside its ellipse.

* :func:`ellipsoid_quadric` -- the blocks of an ellipsoid with semi-axes ``s`` posed at
  ``(R, t)`` in the camera: ``Q = T^-T diag(1/s^2, -1) T^-1`` (``A = R S^-2 R^T``,
  ``b = -A t``, ``c = t^T A t - 1``; ``c > 0`` iff the camera is outside it).
* :func:`quadric_to_conic` -- Menezes eq. 15: the ray ``X(s) = (x, s)`` meets the quadric
  where ``x^T A x + 2 s b^T x + s^2 c = 0`` (eq. 14); it is tangent where the discriminant
  vanishes, ``x^T (b b^T - c A) x = 0``, i.e. on the conic ``C = c A - b b^T``.
* :func:`contour_inverse_depth` -- the tangent point's ``s0 = -b^T x / c`` (after eq. 15); the
  3-D point is ``x / s0``, its depth ``1 / s0``.
* :func:`ray_quadric_inverse_depth` -- eq. 14 solved for the nearer intersection (hidden-part
  removal).
"""

from __future__ import annotations

import numpy as np

from humimic.maths.arrays import stack


def ellipsoid_quadric(R: np.ndarray, t: np.ndarray, semi_axes: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blocks ``(A (...,3,3), b (...,3), c (...))`` of the point quadric of ellipsoids with
    semi-axes ``(..., 3)`` (m) along the columns of ``R (..., 3, 3)``, centred at ``t (..., 3)``
    (camera frame)."""
    inv_s2 = 1.0 / np.square(semi_axes)
    A = (R * inv_s2[..., None, :]) @ np.swapaxes(R, -1, -2)
    At = (A @ t[..., None])[..., 0]
    c = np.add.reduce(t * At, axis=-1) - 1.0
    return A, -At, c


def quadric_to_conic(A: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Image conic ``C = c A - b b^T`` of a quadric in the normalised camera (Menezes eq. 15)."""
    return c[..., None, None] * A - b[..., :, None] * b[..., None, :]


def conic_to_ellipse(C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre ``(..., 2)`` and shape matrix ``M (..., 2, 2)`` of the ellipse
    ``(x - c)^T M^-1 (x - c) = 1`` of conics ``C (..., 3, 3)`` (any scale or sign), and a
    ``(...)`` bool that is False where the conic is not a real ellipse."""
    # component form of centre = -C2^-1 c2, kappa = centre^T C2 centre - c33,
    # M = kappa C2^-1 (numpy's batched 2x2 products cost more than the arithmetic)
    a, b, e, d = C[..., 0, 0], C[..., 0, 1], C[..., 1, 0], C[..., 1, 1]
    ux, uy, c33 = C[..., 0, 2], C[..., 1, 2], C[..., 2, 2]
    det = a * d - b * e
    M = np.empty(np.shape(C)[:-2] + (2, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = (b * uy - d * ux) / det
        cy = (e * ux - a * uy) / det
        k = (cx * (a * cx + b * cy) + cy * (e * cx + d * cy) - c33) / det
        M[..., 0, 0], M[..., 0, 1], M[..., 1, 0], M[..., 1, 1] = k * d, -k * b, -k * e, k * a
    centre = stack([cx, cy], -1)
    ok = (det > 0) & (M[..., 0, 0] > 0) & np.logical_and.reduce(np.isfinite(M), axis=(-1, -2))
    return centre, M, ok


def ellipse_axes(M: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Semi-major, semi-minor axis ``(...)`` and the major axis' angle (rad, from +x towards
    +y) of ellipses with shape matrices ``M (..., 2, 2)`` (closed-form 2x2 eigenvalues)."""
    a, b, d = M[..., 0, 0], M[..., 0, 1], M[..., 1, 1]
    half_tr, half_diff = (a + d) / 2.0, (a - d) / 2.0
    r = np.hypot(half_diff, b)
    major = np.sqrt(np.maximum(half_tr + r, 0.0))
    minor = np.sqrt(np.maximum(half_tr - r, 0.0))
    return major, minor, 0.5 * np.arctan2(2.0 * b, a - d)


def ellipse_points(centre: np.ndarray, M: np.ndarray, n: int) -> np.ndarray:
    """``(..., n, 2)`` points on ellipses ``(centre, M)``: ``centre + L (cos psi, sin psi)``
    with ``L L^T = M`` (Cholesky), ``psi = 2 pi k / n``."""
    m00 = np.sqrt(np.maximum(M[..., 0, 0], 1e-300))
    l10 = M[..., 1, 0] / m00
    l11 = np.sqrt(np.maximum(M[..., 1, 1] - l10 * l10, 0.0))
    psi = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    cos, sin = np.cos(psi), np.sin(psi)
    x = centre[..., None, 0] + m00[..., None] * cos
    y = centre[..., None, 1] + l10[..., None] * cos + l11[..., None] * sin
    return np.stack([x, y], axis=-1)


def rotated_ellipse_points(centre: np.ndarray, semi_axes: np.ndarray, cos_t: np.ndarray,
                           sin_t: np.ndarray, unit: np.ndarray) -> np.ndarray:
    """``(..., M, 2)`` points ``centre + R(t) (a cos psi, b sin psi)`` of ellipses with centres
    ``(..., 2)``, semi-axes ``(..., 2)`` (a along the axis turned by ``t`` from +u towards +v)
    and ``cos t``, ``sin t`` ``(...)``, at the parameter angles' ``unit (M, 2)`` =
    ``(cos psi, sin psi)``; all but ``unit`` broadcast together."""
    x = semi_axes[..., :1] * unit[:, 0]
    y = semi_axes[..., 1:] * unit[:, 1]
    c, s = cos_t[..., None], sin_t[..., None]
    return np.stack([centre[..., :1] + c * x - s * y, centre[..., 1:] + s * x + c * y], -1)


def contour_inverse_depth(b: np.ndarray, c: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``s0 = -b^T x / c`` (Menezes, after eq. 15) for image points ``x (..., k, 2)`` on the
    conic of the quadric ``(b (..., 3), c (...))``: the inverse depth of the tangent point."""
    bx = b[..., None, 0] * x[..., 0] + b[..., None, 1] * x[..., 1] + b[..., None, 2]
    return -bx / c[..., None]


def ray_quadric_inverse_depth(A: np.ndarray, b: np.ndarray, c: np.ndarray, x: np.ndarray
                              ) -> np.ndarray:
    """Largest root ``s`` of Menezes eq. 14, ``x^T A x + 2 s b^T x + s^2 c = 0``, for rays
    through image points ``x (..., 2)`` (``A, b, c`` broadcast against them): the inverse depth
    of the nearer intersection with the quadric, or 0 where the ray misses it (the camera must
    be outside: ``c > 0``)."""
    u, v = x[..., 0], x[..., 1]          # component form: fast on long 1-D batches
    xAx = (A[..., 0, 0] * u * u + A[..., 1, 1] * v * v + A[..., 2, 2]
           + 2.0 * (A[..., 0, 1] * u * v + A[..., 0, 2] * u + A[..., 1, 2] * v))
    bx = b[..., 0] * u + b[..., 1] * v + b[..., 2]
    disc = bx * bx - c * xAx
    s = (-bx + np.sqrt(np.maximum(disc, 0.0))) / c
    return np.where(disc >= 0.0, np.maximum(s, 0.0), 0.0)


def conic_to_pixels(C: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The conic in pixel coordinates, ``K^-T C K^-1`` (no distortion)."""
    K_inv = np.linalg.inv(K)
    return K_inv.T @ C @ K_inv


#: Row-major indices of the upper triangle of a symmetric 3x3 matrix: 00 01 02 11 12 22.
UPPER = np.array([0, 1, 2, 4, 5, 8])


def dual_ellipse(B: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """The image ellipse of ellipsoids from their projected *dual* quadric, in components:
    ``B (..., 6)`` the upper triangle (:data:`UPPER`) of ``R S^2 R^T`` and ``t (..., 3)`` the
    centre, both in the normalised camera. The dual quadric ``H diag(S^2, -1) H^T`` (``H`` the
    ellipsoid's pose) projects to the dual conic ``C* = B - t t^T`` (Hartley & Zisserman
    result 8.9, the dual form of Menezes eq. 15); an ellipse with centre ``c`` and shape matrix
    ``M`` has ``C* ∝ [[M - c c^T, -c], [-c^T, -1]]``, so with ``k = t_z^2 - B_22``:
    ``c = (t_xy t_z - B_{xy,2}) / k``, ``M = (B_xy - t_xy t_xy^T) / k + c c^T``. Returns
    ``cx, cy, m00, m01, m11`` and ``k`` (each ``(...)``); a real ellipse needs ``k > 0`` (the
    ellipsoid wholly on one side of the camera's plane ``z = 0``). No inverse, no
    determinant: a third of :func:`quadric_to_conic` then :func:`conic_to_ellipse`'s work."""
    b00, b01, b02, b11, b12, b22 = (B[..., i] for i in range(6))
    tx, ty, tz = t[..., 0], t[..., 1], t[..., 2]
    k = tz * tz - b22
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / k
        cx = (tx * tz - b02) * inv
        cy = (ty * tz - b12) * inv
        m00 = (b00 - tx * tx) * inv + cx * cx
        m01 = (b01 - tx * ty) * inv + cx * cy
        m11 = (b11 - ty * ty) * inv + cy * cy
    return cx, cy, m00, m01, m11, k
