"""Quaternion Jacobians for the EKFs (unit quaternions ``[w, x, y, z]``, Hamilton product).

The operations themselves (product, rotation matrix, rotation vector) are
:mod:`humimic.motion.quat`'s; this module adds their derivatives, each checked against finite
differences in ``tests/test_ekf_quaternion.py``. ``R(q)`` maps child to parent coordinates:
for the interface orientation ``q = q_WI``, ``v_W = R(q) v_I`` and ``R(q)^T = R(q̄)``.
"""

from __future__ import annotations

import numpy as np

from humimic.motion import quat


def left(q: np.ndarray) -> np.ndarray:
    """``L(q)`` with ``q ⊗ r = L(q) r`` (4x4); ``L(q)`` is also ``d(q ⊗ r)/dr``."""
    w, x, y, z = q
    return np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])


def right(r: np.ndarray) -> np.ndarray:
    """``R(r)`` with ``q ⊗ r = R(r) q`` (4x4); ``d(q ⊗ r)/dq``."""
    w, x, y, z = r
    return np.array([[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]])


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` with ``[v]x u = v x u``; broadcasts over leading dimensions ``(..., 3)``."""
    v = np.asarray(v, float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def d_rotate_dq(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d(R(q) v)/dq`` as ``(..., 3, 4)`` for vectors ``v (..., 3)`` (``q`` unit, ``(4,)``).

    From ``R(q) v = v + 2w (u x v) + 2 u x (u x v)`` with ``u = (x, y, z)``: the ``w`` column
    is ``2 u x v``, the ``u`` columns ``2 (-w [v]x + (u.v) I + u v^T - 2 v u^T)``.
    """
    v = np.asarray(v, float)
    w, u = q[0], q[1:]
    J = np.empty(v.shape[:-1] + (3, 4))
    J[..., 0] = 2.0 * np.cross(u, v)
    uv = v @ u
    J[..., 1:] = 2.0 * (-w * skew(v) + uv[..., None, None] * np.eye(3)
                        + u[:, None] * v[..., None, :] - 2.0 * v[..., :, None] * u)
    return J


def d_rotate_T_dq(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d(R(q)^T v)/dq`` as ``(..., 3, 4)``: ``R(q)^T = R(q̄)``, ``dq̄/dq = diag(1,-1,-1,-1)``."""
    J = d_rotate_dq(quat.conj(q), v)
    J[..., 1:] *= -1.0
    return J


def d_rotvec_to_quat(theta: np.ndarray) -> np.ndarray:
    """``d q(θ) / dθ`` (4x3) for the quaternion of a rotation vector ``θ`` (rad).

    ``q(θ) = (cos(t/2), s(t) θ)`` with ``t = |θ|`` and ``s(t) = sin(t/2)/t``; near zero
    ``s ≈ 1/2 - t^2/48`` and ``s'(t)/t ≈ -1/24``.
    """
    theta = np.asarray(theta, float)
    t = float(np.linalg.norm(theta))
    J = np.empty((4, 3))
    if t < 1e-6:
        s, ds_over_t = 0.5 - t * t / 48.0, -1.0 / 24.0
    else:
        s = np.sin(t / 2) / t
        ds_over_t = (0.5 * np.cos(t / 2) * t - np.sin(t / 2)) / t**3
    J[0] = -0.5 * s * theta  # d cos(t/2) / dθ = -sin(t/2)/2 * θ/t
    J[1:] = s * np.eye(3) + ds_over_t * np.outer(theta, theta)
    return J


def d_normalize(q: np.ndarray) -> np.ndarray:
    """``d(q/|q|)/dq`` (4x4): applied to the covariance when the state's ``q`` is renormalised."""
    n2 = float(q @ q)
    J = np.outer(q, q)
    J *= -1.0 / n2
    J[np.diag_indices(4)] += 1.0
    return J / np.sqrt(n2)


def align_sign(q_meas: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """``q_meas`` or ``-q_meas`` (the same rotation), whichever is nearer ``q_ref``."""
    return -q_meas if float(np.dot(q_meas, q_ref)) < 0.0 else q_meas
