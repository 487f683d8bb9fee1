"""Measurement models of the Wii-remote arm EKF (Sugiyama & Miura Sec. IV-B, eqs. 11-24), with
their Jacobians with respect to the 19-number state of :mod:`.motion_model` (eq. 10).

Frames (:mod:`humimic.world.frames`): I is the head camera's, the paper's (x left, y up, z along
the optical axis), projected in OpenCV's axes ``p_cv = R_CV_I p_I``; A is the remote's (z to the
pointing end, y out of the button face, x left when held pointing ahead buttons up, where
``R_IA = I``); W is the paper's world (y up). The state's position ``p_A^I`` is the marker's
centre: eq. 12 projects it directly.

The marker's area (eq. 13). The paper's marker is flat: the area of its four projected
corners, two triangles (eqs. 13-14, :func:`plate_area`). The simulated remote may carry a
sphere instead, whose silhouette is an ellipse of area ``pi fx fy r^2 sqrt(|c|^2 - r^2) /
(c_z^2 - r^2)^(3/2)`` for a centre ``c`` in camera axes (:func:`sphere_area`): the same
measurement, which then carries no orientation.

Pitch and roll (eqs. 19-24) are elevations: eq. 19's ``-arctan(y_P / sqrt(x_P^2 + z_P^2))`` is
the angle of the remote's z axis below I's x-z plane, ``arctan(y_R / ...)`` that of its x axis
above it. With a "down" direction ``d`` they are ``(elev(R z_A, d), -elev(R x_A, d))``
(:func:`pitch_roll`). The paper uses ``d = -y_I`` after subtracting the head's own pitch and
roll in W from the accelerometer's angles (eq. 22): exact only with the head level or the remote
pointing where the head does. :func:`pitch_roll_measurement` gives that (``paper``) or the exact
form (``gravity``: the head's orientation carries W's down into I and the accelerometer's angles
are used as measured).
"""

from __future__ import annotations

import math

import numpy as np

from humimic.estimation.ekf import quaternion as qj
from humimic.estimation.ekf.motion_model import P, Q, W
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics
from humimic.world.frames import GRAVITY_W, R_CV_I

#: State columns each model reads (its Jacobian is over these only).
COLS_P, COLS_Q, COLS_W = np.arange(0, 3), np.arange(3, 7), np.arange(10, 13)
COLS_PQ = np.arange(0, 7)
#: Gravity's magnitude (m/s^2); the Wii's accelerometer reads in units of it.
G0 = float(np.linalg.norm(GRAVITY_W))
#: Up in the paper's W.
UP_W = -GRAVITY_W / G0
_EX, _EY, _EZ = np.eye(3)


def project(p_I: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Pinhole pixel of a point in I and its Jacobian (2x3).  # Sugiyama eq. 12"""
    p_cv = R_CV_I @ p_I
    return K.project(p_cv), K.project_jacobian(p_cv) @ R_CV_I


def centroid(x: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """``h_pA`` (2,) and its Jacobian on :data:`COLS_P` (2x3): the projection of the marker
    centre.  # Sugiyama eq. 12"""
    return project(x[P], K)


def _cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def quad_area(uv: np.ndarray) -> tuple[float, np.ndarray]:
    """Area of the image quadrilateral ``uv`` (4x2, in order) as the triangles (0, 1, 3) and
    (2, 1, 3), and its gradient (4x2).  # Sugiyama eqs. 13-14"""
    area, grad = 0.0, np.zeros((4, 2))
    for k in (0, 2):  # the triangles' apexes; e_1k = p1 - pk, e_3k = p3 - pk
        a, b = uv[1] - uv[k], uv[3] - uv[k]
        c = _cross2(a, b)
        s = 0.5 if c >= 0.0 else -0.5
        area += s * c
        da, db = s * np.array([b[1], -b[0]]), s * np.array([-a[1], a[0]])
        grad[1] += da
        grad[3] += db
        grad[k] -= da + db
    return area, grad


def plate_area(x: np.ndarray, K: Intrinsics, corners_A: np.ndarray
               ) -> tuple[float, np.ndarray]:
    """``h_areaA`` (px^2) and its Jacobian on :data:`COLS_PQ` (1x7) of a flat marker whose
    corners relative to its centre are ``corners_A`` (4x3, in order, frame A).
    # Sugiyama eqs. 13-14"""
    p, q = x[P], x[Q]
    Rq = rotation(q)
    uv = np.empty((4, 2))
    Js = []
    for k, c in enumerate(corners_A):
        uv[k], J = project(p + Rq @ c, K)
        Js.append(J)
    area, grad = quad_area(uv)
    H = np.zeros((1, 7))
    for k, c in enumerate(corners_A):
        g = grad[k] @ Js[k]  # d area / d corner (3,)
        H[0, 0:3] += g
        H[0, 3:7] += g @ qj.d_rotate_dq(q, c)
    return area, H


def sphere_area(x: np.ndarray, K: Intrinsics, radius: float) -> tuple[float, np.ndarray]:
    """``h_areaA`` (px^2) and its Jacobian on :data:`COLS_P` (1x3) of a spherical marker of
    ``radius`` (m): the ellipse its silhouette projects to (see the module docstring)."""
    c = R_CV_I @ x[P]
    r2 = radius * radius
    g, hz = float(c @ c) - r2, c[2] * c[2] - r2
    area = math.pi * K.fx * K.fy * r2 * math.sqrt(g) / hz**1.5
    grad_c = area * (c / g - 3.0 * c[2] / hz * _EZ)
    return area, (grad_c @ R_CV_I)[None]


def gyro(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h_wA = w_A`` and its Jacobian on :data:`COLS_W` (3x3).  # Sugiyama eq. 15"""
    return x[W].copy(), np.eye(3)


def relative_rate(z_gyro_A: np.ndarray, q_IA: np.ndarray, w_head_I: np.ndarray,
                  dt: float) -> np.ndarray:
    """The remote's angular velocity relative to the head, in A, from its raw gyro reading
    ``z_gyro_A`` (rad/s, which includes the head's rotation) over ``dt`` (s).

    Sugiyama eqs. 16-18, our reading of the garbled chain: with the head's body-frame rotation
    over the step ``dq_I = q(w_I dt)`` (the paper's ``Delta q_I^W`` between consecutive head
    estimates) and the remote's orientation ``q_IA``, ``R_IA(t + dt) = dq_I^-1 R_IA(t) q(z dt)``,
    so the remote's increment relative to the head is ``q_IA^-1 (x) dq_I^-1 (x) q_IA (x)
    q(z dt)``, and the rate is its rotation vector over ``dt`` (eq. 18:
    ``2 arccos(q_r) / (dt |q_v|) q_v``).
    """
    qc = (q_IA[0], -q_IA[1], -q_IA[2], -q_IA[3])
    dq = qmul(qmul(qc, qexp(-dt * np.asarray(w_head_I))),
               qmul(q_IA, qexp(dt * np.asarray(z_gyro_A))))
    return qlog(dq) / dt


# ---- one quaternion at a time (the batched humimic.motion.quat costs 10x more per call) ----
def qmul(a, b) -> tuple[float, float, float, float]:
    """The Hamilton product ``a (x) b`` of two quaternions (wxyz)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def qexp(r) -> tuple[float, float, float, float]:
    """The quaternion of the rotation vector ``r``."""
    x, y, z = float(r[0]), float(r[1]), float(r[2])
    th = math.sqrt(x * x + y * y + z * z)
    k = math.sin(th / 2.0) / th if th > 1e-8 else 0.5 - th * th / 48.0
    return (math.cos(th / 2.0), k * x, k * y, k * z)


def qlog(q) -> np.ndarray:
    """The rotation vector (angle in [0, pi]) of a unit quaternion."""
    w, x, y, z = q
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 * math.atan2(s, w) / s if s > 1e-12 else 2.0
    return np.array([k * x, k * y, k * z])


def rotation(q) -> np.ndarray:
    """``R(q)`` of one unit quaternion (as :func:`humimic.motion.quat.to_matrix`)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def elevation(u: np.ndarray, d: np.ndarray) -> tuple[float, np.ndarray]:
    """Angle of ``u`` out of the plane orthogonal to the unit ``d``, positive towards ``d``
    (``arctan(d.u / sqrt(|u|^2 - (d.u)^2))``, scale-invariant), and its gradient in ``u``."""
    s = float(d @ u)
    n2 = float(u @ u)
    c = math.sqrt(max(n2 - s * s, 1e-300))
    grad = (c * d - s * (u - s * d) / c) / n2
    return math.atan2(s, c), grad


def pitch_roll(x: np.ndarray, d_I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h_PRA`` (2,): the pitch (the remote's z axis below the plane orthogonal to the down
    direction ``d_I``) and roll (its x axis above it), and the Jacobian on :data:`COLS_Q`
    (2x4).  # Sugiyama eqs. 19-21"""
    q = x[Q]
    Rq = rotation(q)
    H = np.empty((2, 4))
    out = np.empty(2)
    for i, (e, sign) in enumerate(((_EZ, 1.0), (_EX, -1.0))):
        ang, g = elevation(Rq @ e, d_I)
        out[i] = sign * ang
        H[i] = sign * (g @ qj.d_rotate_dq(q, e))
    return out, H


def accel_pitch_roll(f_A: np.ndarray) -> np.ndarray:
    """``z_wii``: the remote's pitch and roll (rad) from its accelerometer's specific force
    ``f_A`` (at rest ``f`` points up, so W's down in A is ``-f / |f|``)."""
    d_A = -np.asarray(f_A, float) / np.linalg.norm(f_A)
    return np.array([math.asin(min(1.0, max(-1.0, d_A[2]))),
                     -math.asin(min(1.0, max(-1.0, d_A[0])))])


def accel_is_static(f_A: np.ndarray, R_IA: np.ndarray, R_WI: np.ndarray,
                    tol_g: float = 0.02) -> bool:
    """The paper's gate ``|a_wii^I - g^I| <= 0.02``: the accelerometer's reading taken into I
    with the remote's estimated orientation against gravity in I from the head's, in units of
    g (the Wii's). A test on the norms alone would pass sideways accelerations of up to 0.2 g
    (an 11 deg tilt error); this one also fails once the orientation is more than about 1 deg
    off, which the gyro and the start pose prevent."""
    e = R_IA @ f_A - R_WI.T @ (G0 * UP_W)
    return float(e @ e) <= (tol_g * G0) ** 2


def head_pitch_roll(R_WI: np.ndarray) -> np.ndarray:
    """The head camera's pitch and roll in W (its z axis below, its x axis above the
    horizontal).  # Sugiyama eqs. 22-24"""
    return np.array([elevation(R_WI[:, 2], -UP_W)[0], -elevation(R_WI[:, 0], -UP_W)[0]])


def pitch_roll_measurement(f_A: np.ndarray, R_WI: np.ndarray, mode: str
                           ) -> tuple[np.ndarray, np.ndarray]:
    """The measurement ``z_PRA`` and the down direction ``d_I`` its model uses.

    ``paper``: ``z_wii - (head pitch, head roll)`` against ``d_I = -y_I`` (eq. 22);
    ``gravity``: ``z_wii`` against ``d_I = R_WI^T down_W``, exact for any head orientation."""
    z = accel_pitch_roll(f_A)
    if mode == "paper":
        return z - head_pitch_roll(R_WI), -_EY
    if mode == "gravity":
        return z, -(R_WI.T @ UP_W)
    raise ValueError(f"pitch/roll mode must be 'paper' or 'gravity', got {mode!r}")


def _level_frame(up: np.ndarray) -> np.ndarray:
    """Columns ``x = y cross z``, ``y = up``, ``z`` = the frame's own z made horizontal."""
    y = up / np.linalg.norm(up)
    z = _EZ - y[2] * y
    z /= np.linalg.norm(z)
    return np.column_stack([np.cross(y, z), y, z])


def start_pose(f_A: np.ndarray, R_WI: np.ndarray) -> np.ndarray:
    """The unit ``q_A^I`` (wxyz) of a remote held still "directed to the front" (Sugiyama
    Sec. IV): its pitch and roll from the accelerometer, its pointing axis made horizontal
    along the head's optical axis made horizontal (the yaw nothing else measures)."""
    return quat.from_matrix(_level_frame(R_WI.T @ UP_W) @ _level_frame(f_A).T)
