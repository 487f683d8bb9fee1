"""The random-jerk quaternion motion model of Sugiyama & Miura (eqs. 3-4), with its Jacobians.

One rigid body (the head camera in the world for the SLAM, the Wii remote in the head frame for
the arm EKF, Sugiyama eq. 10) in a parent frame P::

    x = (p, q, v, w, a, b)  in R^19: position (3), orientation (4, wxyz, P <- body), velocity
                            (3), body angular velocity (3), acceleration (3), accelerometer
                            bias (3); p, v, a, b in P
    n = (j, alpha, b')      the system noise: jerk (3, P), angular acceleration (3, body),
                            bias variation (3)

Our reading of eqs. 3-4 (the text's frames are inconsistent): ``q <- q (x) q(w dt + alpha
dt^2/2)`` multiplies on the right, so ``w`` and ``alpha`` are *body-frame* rates (what a gyro
measures, Sugiyama eq. 15: ``h = w``); eq. 4's cross products with ``v`` and ``a`` (which live in
P) therefore take them into P first: ``a' = j + (R(q) alpha) x v + (R(q) w) x a``. The noise is
held constant over the step with the paper's standard deviations (sigma_j = 15 m/s^3,
sigma_alpha = 15 rad/s^2, sigma_b = 1e-3), as in Davison's and Civera's EKF SLAM: the process
noise is ``G diag(sigma^2) G^T`` with ``G = df/dn`` at ``n = 0``.

Quaternions are scalar-first (Sugiyama eq. 17, MuJoCo), Hamilton product
(:mod:`humimic.motion.quat`). ``R(q)`` is the quadratic form ``(w^2 - u.u) I + 2 u u^T + 2 w
[u]x``, a rotation for unit ``q``; the filter renormalises after each update
(:func:`normalize_quaternion`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

DIM = 19
NOISE_DIM = 9
P, Q, V, W, A, B = (slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13), slice(13, 16),
                    slice(16, 19))
_I3 = np.eye(3)


@dataclass(frozen=True)
class JerkNoise:
    """Standard deviations of the system noise (Sugiyama Sec. III-A)."""

    jerk: float = 15.0
    """sigma_j (m/s^3)."""
    angular_acc: float = 15.0
    """sigma_alpha (rad/s^2)."""
    bias: float = 1e-3
    """sigma_b of the accelerometer-bias variation (m/s^3)."""

    def covariance(self) -> np.ndarray:
        return _noise_covariance(self.jerk, self.angular_acc, self.bias)


@functools.lru_cache(maxsize=16)
def _noise_covariance(jerk: float, angular_acc: float, bias: float) -> np.ndarray:
    Qn = np.diag(np.repeat([jerk**2, angular_acc**2, bias**2], 3))
    Qn.flags.writeable = False
    return Qn


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` with ``[v]x u = v x u``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of two 3-vectors (``np.cross`` costs ten times more on one pair)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def quat_left(q: np.ndarray) -> np.ndarray:
    """``L(q)`` with ``q (x) p = L(q) p``."""
    w, x, y, z = q
    return np.array([[w, -x, -y, -z], [x, w, -z, y], [y, z, w, -x], [z, -y, x, w]])


def quat_right(p: np.ndarray) -> np.ndarray:
    """``R(p)`` with ``q (x) p = R(p) q``."""
    w, x, y, z = p
    return np.array([[w, -x, -y, -z], [x, w, z, -y], [y, -z, w, x], [z, y, -x, w]])


def quat_exp(r: np.ndarray) -> np.ndarray:
    """``q(r)``, the quaternion of the rotation vector ``r`` (as :func:`quat.from_rotvec`)."""
    th = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    k = math.sin(th / 2.0) / th if th > 1e-8 else 0.5 - th * th / 48.0
    return np.array([math.cos(th / 2.0), k * r[0], k * r[1], k * r[2]])


def rotation(q: np.ndarray) -> np.ndarray:
    """The quadratic form ``R(q)`` (a rotation matrix for unit ``q``; ``|q|^2`` times one
    otherwise)."""
    w, x, y, z = q
    return np.array([
        [w * w + x * x - y * y - z * z, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z]])


def d_rotate_dq(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d (R(q) v) / dq`` (3x4) of the quadratic form."""
    w, u = q[0], q[1:]
    out = np.empty((3, 4))
    out[:, 0] = 2.0 * (w * v + cross(u, v))
    out[:, 1:] = 2.0 * (float(u @ v) * _I3 + np.outer(u, v) - np.outer(v, u) - w * skew(v))
    return out


def d_exp_dr(r: np.ndarray) -> np.ndarray:
    """``d q(r) / dr`` (4x3) of the quaternion of a rotation vector (Taylor series near 0)."""
    th = math.sqrt(float(r @ r))
    if th < 1e-6:  # sin(th/2)/th -> 1/2, the r r^T coefficient -> -1/24, dw/dr -> -r/4
        return np.vstack([-0.25 * r, 0.5 * _I3 - np.outer(r, r) / 24.0])
    s, c = math.sin(th / 2.0), math.cos(th / 2.0)
    return np.vstack([-s / (2.0 * th) * r,
                      s / th * _I3 + np.outer(r, r) * (c / (2.0 * th**2) - s / th**3)])


def predict_state(x: np.ndarray, dt: float, n: np.ndarray | None = None) -> np.ndarray:
    """``f(x, n)`` over ``dt`` (s), noise ``n`` (9,) or zero.  # Sugiyama eqs. 3-4"""
    p, q, v, w, a, b = x[P], x[Q], x[V], x[W], x[A], x[B]
    j, al, db = (np.zeros(3),) * 3 if n is None else (n[0:3], n[3:6], n[6:9])
    Rq = rotation(q)
    a_dot = j + cross(Rq @ al, v) + cross(Rq @ w, a)  # eq. 4
    out = np.empty(DIM)
    out[P] = p + v * dt + a * (dt * dt / 2.0) + a_dot * (dt**3 / 6.0)
    out[Q] = quat_right(quat_exp(w * dt + al * (dt * dt / 2.0))) @ q
    out[V] = v + a * dt + a_dot * (dt * dt / 2.0)
    out[W] = w + al * dt
    out[A] = a + a_dot * dt
    out[B] = b + db * dt
    return out


def jacobians(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``F = df/dx`` (19x19) and ``G = df/dn`` (19x9) at ``n = 0``."""
    q, v, w, a = x[Q], x[V], x[W], x[A]
    Rq = rotation(q)
    w_p = Rq @ w
    dc_da = skew(w_p)  # c = (R w) x a = -a x (R w)
    dc_dw = -skew(a) @ Rq
    dc_dq = -skew(a) @ d_rotate_dq(q, w)
    r = w * dt
    dq = quat_exp(r)
    L_dexp = quat_left(q) @ d_exp_dr(r)
    F = np.eye(DIM)
    for rows, k in ((P, dt**3 / 6.0), (V, dt * dt / 2.0), (A, dt)):
        F[rows, Q] = k * dc_dq
        F[rows, W] = k * dc_dw
        F[rows, A] += k * dc_da
    F[P, V] = dt * _I3
    F[P, A] += (dt * dt / 2.0) * _I3
    F[V, A] += dt * _I3
    F[Q, Q] = quat_right(dq)
    F[Q, W] = L_dexp * dt
    G = np.zeros((DIM, NOISE_DIM))
    da_dal = -skew(v) @ Rq
    for rows, k in ((P, dt**3 / 6.0), (V, dt * dt / 2.0), (A, dt)):
        G[rows, 0:3] = k * _I3
        G[rows, 3:6] = k * da_dal
    G[Q, 3:6] = L_dexp * (dt * dt / 2.0)
    G[W, 3:6] = dt * _I3
    G[B, 6:9] = dt * _I3
    return F, G


def predict(x: np.ndarray, Pc: np.ndarray, dt: float, noise: JerkNoise
            ) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction of the interface state: ``f(x)``, ``F P F^T + G Q_n G^T``."""
    if dt <= 0.0:
        return x, Pc
    F, G = jacobians(x, dt)
    Pn = F @ Pc @ F.T + G @ noise.covariance() @ G.T
    return predict_state(x, dt), 0.5 * (Pn + Pn.T)


def normalize_quaternion(x: np.ndarray, Pc: np.ndarray, sl: slice = Q
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Renormalise the quaternion at ``sl`` and map its covariance through ``d(q/|q|)/dq``
    (Civera et al.)."""
    q = x[sl]
    nq = float(np.linalg.norm(q))
    J = (np.eye(4) - np.outer(q, q) / (nq * nq)) / nq
    x = x.copy()
    x[sl] = q / nq
    Pc = Pc.copy()
    Pc[sl, :] = J @ Pc[sl, :]
    Pc[:, sl] = Pc[:, sl] @ J.T
    return x, Pc
