"""Map features: inverse-depth and XYZ points, their image measurement and initialisation.

Sugiyama & Miura eq. 9 after Montiel, Civera & Davison (RSS 2006) and Civera, Davison &
Montiel (T-RO 2008). A feature first seen from the optical centre ``c = (x0, y0, z0)`` along
the direction ``m(θ, φ)`` at inverse depth ``ρ`` is ``y = (x0, y0, z0, θ, φ, ρ)``; the point is
``c + m/ρ``. Once its depth is well determined (Civera's linearity index below 0.1) it is
converted to plain XYZ, three numbers instead of six.

``m(θ, φ) = (cos φ sin θ, -sin φ, cos φ cos θ)`` is singular along the reference frame's y
axis, which in the paper's W points up: the head camera never looks straight up or down.

The interface frame I is the paper's (x left, y up, z along the optical axis: eq. 8's
``u = u0 - f k_u x/z``); pixels are projected in OpenCV's camera axes (x right, y down), which
are ``R_cv_I`` away (``p_cv = R_cv_I p_I``), by
:meth:`humimic.sensors.camera_model.Intrinsics.project` and its Jacobian. Pixels are those of
the undistorted image (the estimator undistorts every frame first).

Every function is vectorised over features: ``(k, 6)`` inverse-depth or ``(k, 3)`` XYZ rows.
"""

from __future__ import annotations

import numpy as np

from humimic.estimation.ekf import quaternion as qj
from humimic.estimation.ekf.motion_model import rotmat
from humimic.sensors.camera_model import Intrinsics

ID_DIM, XYZ_DIM = 6, 3
#: Civera et al. (2008): switch to XYZ below this linearity index.
LINEARITY_THRESHOLD = 0.1


def direction(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``m(θ, φ)`` ``(..., 3)``, a unit vector.  # Sugiyama eq. 9 (Montiel et al. 2006)"""
    cp = np.cos(phi)
    return np.stack([cp * np.sin(theta), -np.sin(phi), cp * np.cos(theta)], axis=-1)


def d_direction(theta: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``dm/dθ`` and ``dm/dφ``, each ``(..., 3)``."""
    ct, st, cp, sp = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    zero = np.zeros_like(ct)
    return (np.stack([cp * ct, zero, -cp * st], axis=-1),
            np.stack([-sp * st, -cp, -sp * ct], axis=-1))


def angles(h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Azimuth ``θ``, elevation ``φ`` of directions ``h (..., 3)`` and their Jacobian
    ``d(θ, φ)/dh`` ``(..., 2, 3)``."""
    hx, hy, hz = h[..., 0], h[..., 1], h[..., 2]
    r2 = hx * hx + hz * hz
    r = np.sqrt(r2)
    n2 = r2 + hy * hy
    J = np.empty(h.shape[:-1] + (2, 3))
    J[..., 0, 0], J[..., 0, 1], J[..., 0, 2] = hz / r2, 0.0, -hx / r2
    J[..., 1, 0], J[..., 1, 1], J[..., 1, 2] = hy * hx / (r * n2), -r / n2, hy * hz / (r * n2)
    return np.arctan2(hx, hz), np.arctan2(-hy, r), J


def to_xyz(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """XYZ points ``c + m/ρ`` ``(k, 3)`` and ``d(xyz)/dy`` ``(k, 3, 6)`` (Civera 2008 eq. 3)."""
    th, ph, rho = y[:, 3], y[:, 4], y[:, 5]
    m = direction(th, ph)
    dth, dph = d_direction(th, ph)
    J = np.zeros((len(y), 3, 6))
    J[:, :, 0:3] = np.eye(3)
    J[:, :, 3] = dth / rho[:, None]
    J[:, :, 4] = dph / rho[:, None]
    J[:, :, 5] = -m / (rho * rho)[:, None]
    return y[:, 0:3] + m / rho[:, None], J


def linearity_index(y: np.ndarray, sigma_rho: np.ndarray, p_cam: np.ndarray) -> np.ndarray:
    """Civera et al. (2008) ``L_d = 4 σ_d cos α / d``: ``σ_d = σ_ρ/ρ^2``, ``d`` the distance
    from the current optical centre ``p_cam`` to the point, ``α`` the parallax angle between the
    first and the current ray. Small: the XYZ point is nearly Gaussian (convert below 0.1)."""
    rho = y[:, 5]
    m = direction(y[:, 3], y[:, 4])
    x = y[:, 0:3] + m / rho[:, None]
    h2 = x - p_cam
    d = np.linalg.norm(h2, axis=1)
    cos_a = np.einsum("ki,ki->k", m, h2) / d
    return 4.0 * sigma_rho / (rho * rho) * np.abs(cos_a) / d


def camera_rays(y: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rays to the features in the interface frame (``(k, 3)``, any positive scale) and the same
    rays in W before rotation. Inverse depth: ``ρ (c - p) + m(θ, φ)``; XYZ: ``x - p``.
    # Sugiyama eq. 9"""
    if y.shape[1] == ID_DIM:
        d_W = y[:, 5:6] * (y[:, 0:3] - p) + direction(y[:, 3], y[:, 4])
    else:
        d_W = y - p
    return d_W @ rotmat(q), d_W  # rows: R(q)^T d_W


def observe(y: np.ndarray, p: np.ndarray, q: np.ndarray, intr: Intrinsics,
            R_cv_I: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Predicted pixels of features ``y`` seen from the interface pose ``(p, q)`` (``q = q_WI``)
    through a camera whose OpenCV axes are ``R_cv_I`` from I, with Jacobians.

    Returns ``h (k, 2)``, ``H_pq (k, 2, 7)`` with respect to ``(p, q)``, ``H_y (k, 2, dim)``
    with respect to the feature, and the depth ``z (k,)`` of each ray in the camera frame
    (``h`` is meaningless where ``z <= 0``: the feature is behind the camera).
    # Sugiyama eqs. 8-9
    """
    d_I, d_W = camera_rays(y, p, q)
    d_C = d_I @ R_cv_I.T
    R = rotmat(q)
    h = intr.project(d_C)
    Jp = intr.project_jacobian(d_C) @ R_cv_I  # (k, 2, 3): d h / d d_I
    JR = Jp @ R.T  # d h / d d_W
    k = len(y)
    H_pq = np.empty((k, 2, 7))
    H_pq[:, :, 3:7] = Jp @ qj.d_rotate_T_dq(q, d_W)
    if y.shape[1] == ID_DIM:
        rho = y[:, 5]
        H_pq[:, :, 0:3] = -rho[:, None, None] * JR
        dth, dph = d_direction(y[:, 3], y[:, 4])
        H_y = np.empty((k, 2, ID_DIM))
        H_y[:, :, 0:3] = rho[:, None, None] * JR
        H_y[:, :, 3] = np.einsum("kij,kj->ki", JR, dth)
        H_y[:, :, 4] = np.einsum("kij,kj->ki", JR, dph)
        H_y[:, :, 5] = np.einsum("kij,kj->ki", JR, y[:, 0:3] - p)
    else:
        H_pq[:, :, 0:3] = -JR
        H_y = JR
    return h, H_pq, H_y, d_C[:, 2]


def initialise(uv: np.ndarray, p: np.ndarray, q: np.ndarray, intr: Intrinsics,
               R_cv_I: np.ndarray, rho0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """New inverse-depth features from undistorted pixels ``uv (k, 2)`` seen from ``(p, q)``
    (camera axes ``R_cv_I`` from I, as :func:`observe`).

    Civera et al. (2008) sec. III-C: ``y = (p, θ, φ, ρ0)`` with ``(θ, φ)`` the ray's angles in W.
    Returns ``y (k, 6)``, ``dy/d(p, q)`` ``(k, 6, 7)`` and ``dy/d(u, v, ρ)`` ``(k, 6, 3)``; the
    new covariance is ``J_pq P_pq J_pq^T + J_z diag(σ_uv^2, σ_uv^2, σ_ρ^2) J_z^T``.
    """
    uv = np.atleast_2d(np.asarray(uv, float))
    k = len(uv)
    h_C = np.ones((k, 3))
    h_C[:, 0] = (uv[:, 0] - intr.cx) / intr.fx
    h_C[:, 1] = (uv[:, 1] - intr.cy) / intr.fy
    R = rotmat(q) @ R_cv_I.T  # W <- camera axes
    h_W = h_C @ R.T
    th, ph, dang = angles(h_W)
    y = np.empty((k, ID_DIM))
    y[:, 0:3] = p
    y[:, 3], y[:, 4], y[:, 5] = th, ph, rho0
    J_pq = np.zeros((k, ID_DIM, 7))
    J_pq[:, 0:3, 0:3] = np.eye(3)
    J_pq[:, 3:5, 3:7] = dang @ qj.d_rotate_dq(q, h_C @ R_cv_I)  # rays in I
    J_z = np.zeros((k, ID_DIM, 3))
    J_z[:, 3:5, 0] = dang @ R[:, 0] / intr.fx
    J_z[:, 3:5, 1] = dang @ R[:, 1] / intr.fy
    J_z[:, 5, 2] = 1.0
    return y, J_pq, J_z
