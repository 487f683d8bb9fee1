"""Measurement models of the Wii-remote arm EKF (Sugiyama & Miura Sec. IV-B, eqs. 11-24), with
their Jacobians with respect to the state of :mod:`~humimic.estimation.ekf.jerk_model`.

Frames. ``I`` is the head camera's frame with OpenCV axes (x right, y down, z forward); the
paper's ``I`` has x left and y up (its eq. 12 has ``u0 - f ku x/z``), a half turn about z, so its
formulas carry over with the signs below. ``A`` is the Wii remote's frame: z along its pointing
axis, x to its right, y down, so that ``q_A^I`` is the identity when the remote points along the
optical axis held flat - the start pose the paper requires ("direct the Wii Remote to front").
The state's position ``p_A^I`` is the centre of the marker's face; the marker is a flat
rectangle of known size (its corners ``c_k`` in ``A``).

Pitch and roll (eqs. 19-24) are elevations: the angle of the remote's z axis (pitch) and x axis
(roll) out of the plane orthogonal to a "down" direction ``d``, positive towards ``d``. The
paper measures them in I (``d = (0, 1, 0)``: its ``arctan(y / sqrt(x^2 + z^2))`` with y up, sign
flipped with the axis) after subtracting the head's own pitch and roll in the world from the
remote's accelerometer angles (eq. 22) - exact only while the head is level or the remote points
where the head does. :func:`pitch_roll_measurement` gives that (``paper``) or the exact form
(``gravity``: the head's orientation carries the world's down into I, ``d = R_WI^T d_W``, and the
accelerometer angles are used as measured).
"""

from __future__ import annotations

import numpy as np

from humimic.estimation.ekf.jerk_model import DIM, P, Q, W, d_rotate_dq, rotation
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics

#: Columns: the remote's frame A in the MuJoCo site frame of the Wii remote (x along the remote,
#: y left, z up): x_A = -y, y_A = -z, z_A = x.
R_SITE_A = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
#: The world's down in MuJoCo's z-up world frame.
DOWN_WORLD = np.array([0.0, 0.0, -1.0])
#: Standard gravity (m/s^2): the Wii's accelerometer reads in units of g.
G0 = 9.80665
_EZ, _EX = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])


def project(p_cam: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Undistorted pixel of a camera-frame point and its Jacobian (2x3).  # Sugiyama eq. 12"""
    x, y, z = p_cam
    uv = np.array([K.fx * x / z + K.cx, K.fy * y / z + K.cy])
    J = np.array([[K.fx / z, 0.0, -K.fx * x / (z * z)], [0.0, K.fy / z, -K.fy * y / (z * z)]])
    return uv, J


def centroid(x: np.ndarray, K: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """``h_pA`` (2,) and ``dh/dx`` (2x19): the projection of the marker centre.  # eq. 12"""
    uv, J = project(x[P], K)
    H = np.zeros((2, DIM))
    H[:, P] = J
    return uv, H


def _cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def quad_area(uv: np.ndarray) -> tuple[float, np.ndarray]:
    """Area of the image quadrilateral ``uv`` (4x2, in order) as two triangles (0, 1, 3) and
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


def marker_area(x: np.ndarray, K: Intrinsics, corners_A: np.ndarray
                ) -> tuple[float, np.ndarray]:
    """``h_areaA`` (px^2) and ``dh/dx`` (1x19): the projected area of the marker whose corners
    are ``corners_A`` (4x3, in order around it) in A.  # Sugiyama eqs. 13-14"""
    p, q = x[P], x[Q]
    Rq = rotation(q)
    uv = np.empty((4, 2))
    Js = []
    for k, c in enumerate(corners_A):
        uv[k], J = project(p + Rq @ c, K)
        Js.append(J)
    area, grad = quad_area(uv)
    H = np.zeros((1, DIM))
    for k, c in enumerate(corners_A):
        g = grad[k] @ Js[k]  # d area / d corner (3,)
        H[0, P] += g
        H[0, Q] += g @ d_rotate_dq(q, c)
    return area, H


def gyro(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h_wA = w_A`` and its Jacobian (3x19).  # Sugiyama eq. 15"""
    H = np.zeros((3, DIM))
    H[:, W] = np.eye(3)
    return x[W].copy(), H


def relative_rate(z_gyro_A: np.ndarray, q_IA: np.ndarray, w_head_I: np.ndarray,
                  dt: float) -> np.ndarray:
    """The remote's angular velocity relative to the head, in A, from its raw gyro reading
    ``z_gyro_A`` (rad/s, which includes the head's rotation) over ``dt`` (s).

    Sugiyama eqs. 16-18: with the head's body-frame rotation over the step ``dq_I = q(w_I dt)``
    (the paper's ``Delta q_I^W`` between consecutive head estimates) and the remote's
    orientation ``q_IA`` in I, ``R_IA(t + dt) = dq_I^-1 R_IA(t) q(z dt)``, so the remote's
    increment relative to the head is ``q_IA^-1 (x) dq_I^-1 (x) q_IA (x) q(z dt)`` and the rate
    is its rotation vector over ``dt`` (eq. 18: ``2 arccos(q_r) / (dt |q_v|) q_v``).
    """
    dq = quat.mul(quat.mul(quat.conj(q_IA), quat.from_rotvec(-np.asarray(w_head_I) * dt)),
                  quat.mul(q_IA, quat.from_rotvec(np.asarray(z_gyro_A) * dt)))
    return quat.to_rotvec(dq) / dt


def elevation(u: np.ndarray, d: np.ndarray) -> tuple[float, np.ndarray]:
    """Angle of ``u`` out of the plane orthogonal to the unit ``d``, positive towards ``d``
    (``arctan(d.u / sqrt(|u|^2 - (d.u)^2))``, scale-invariant), and its gradient in ``u``."""
    s = float(d @ u)
    n2 = float(u @ u)
    c = float(np.sqrt(max(n2 - s * s, 1e-300)))
    grad = (c * d - s * (u - s * d) / c) / n2
    return float(np.arctan2(s, c)), grad


def pitch_roll(x: np.ndarray, d_I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h_PRA`` (2,): the elevations of the remote's z (pitch) and x (roll) axes towards the
    down direction ``d_I`` in I, and the Jacobian (2x19).  # Sugiyama eqs. 19-21"""
    q = x[Q]
    Rq = rotation(q)
    H = np.zeros((2, DIM))
    out = np.empty(2)
    for i, e in enumerate((_EZ, _EX)):
        out[i], g = elevation(Rq @ e, d_I)
        H[i, Q] = g @ d_rotate_dq(q, e)
    return out, H


def accel_pitch_roll(f_A: np.ndarray) -> np.ndarray:
    """The remote's pitch and roll (rad) from its accelerometer's specific force ``f_A`` (in A):
    at rest ``f`` points up, so the world's down in A is ``-f / |f|``.  # Sugiyama z_wii"""
    d_A = -np.asarray(f_A, float) / np.linalg.norm(f_A)
    return np.array([np.arcsin(np.clip(d_A[2], -1, 1)), np.arcsin(np.clip(d_A[0], -1, 1))])


def accel_is_static(f_A: np.ndarray, R_IA: np.ndarray, R_WI: np.ndarray,
                    tol_g: float = 0.02) -> bool:
    """The paper's gate ``|a_wii^I - g^I| <= 0.02``: the accelerometer's reading taken into I
    with the remote's estimated orientation against gravity in I from the head's, in units of
    g (the Wii's). A test on the norms alone would pass sideways accelerations of up to 0.2 g
    (an 11 deg tilt error); this one also fails once the orientation is more than about 1 deg
    off, which the gyro and the start pose prevent."""
    up_I = R_WI.T @ np.array([0.0, 0.0, G0])
    return float(np.linalg.norm(R_IA @ f_A - up_I)) <= tol_g * G0


def head_pitch_roll(R_WI: np.ndarray) -> np.ndarray:
    """The head camera's pitch and roll in the world (elevations of its z and x axes towards
    the world's down).  # Sugiyama eqs. 22-24"""
    return np.array([elevation(R_WI[:, 2], DOWN_WORLD)[0], elevation(R_WI[:, 0], DOWN_WORLD)[0]])


def pitch_roll_measurement(f_A: np.ndarray, R_WI: np.ndarray, mode: str
                           ) -> tuple[np.ndarray, np.ndarray]:
    """The measurement ``z_PRA`` and the down direction ``d_I`` its model uses.

    ``paper``: ``z_wii - (head pitch, head roll)`` against ``d_I = (0, 1, 0)`` (eq. 22);
    ``gravity``: ``z_wii`` against ``d_I = R_WI^T d_W``, exact for any head orientation."""
    z = accel_pitch_roll(f_A)
    if mode == "paper":
        return z - head_pitch_roll(R_WI), np.array([0.0, 1.0, 0.0])
    if mode == "gravity":
        return z, R_WI.T @ DOWN_WORLD
    raise ValueError(f"pitch/roll mode must be 'paper' or 'gravity', got {mode!r}")


def _level_frame(down: np.ndarray) -> np.ndarray:
    """Columns x, y = ``down``, z = the frame's own z made horizontal (orthogonal to down)."""
    y = down / np.linalg.norm(down)
    z = np.array([0.0, 0.0, 1.0]) - y[2] * y
    z /= np.linalg.norm(z)
    return np.column_stack([np.cross(y, z), y, z])


def start_pose(f_A: np.ndarray, R_WI: np.ndarray) -> np.ndarray:
    """The unit ``q_A^I`` (wxyz) of a remote held still "directed to the front" (Sugiyama
    Sec. IV): its pitch and roll from the accelerometer, and its pointing axis made horizontal
    along the head's optical axis made horizontal (the yaw nothing else measures)."""
    L_I = _level_frame(R_WI.T @ DOWN_WORLD)
    L_A = _level_frame(-np.asarray(f_A, float))
    return quat.from_matrix(L_I @ L_A.T)
