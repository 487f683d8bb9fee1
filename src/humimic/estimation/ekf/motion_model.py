"""The interface's random-jerk motion model and its inertial measurement models.

Sugiyama & Miura (2011), sec. III-A/B, after Armesto et al. (2007). The state of the interface
(the head camera, or the Wii remote for the arm EKF) is, in this order (Sugiyama eq. 2)::

    x = [p (3), q (4), v (3), ω (3), a (3), b (3)]        19 numbers

``p, v, a`` position, velocity and acceleration in the reference frame (W for the head; m,
m/s, m/s^2); ``q`` the orientation ``q_WI`` (unit, ``[w, x, y, z]``, ``v_W = R(q) v_I``);
``ω`` the angular velocity (rad/s); ``b`` the accelerometer bias (m/s^2, in W as eq. 7).

**Which frame ω is in.** Eq. 3 right-multiplies the increment, ``q ⊗ q(ω Δt)``, which makes
``ω`` the angular velocity in the *body* frame I (as Davison's MonoSLAM, whose notation also
writes W). Eq. 4's ``α × v + ω × a`` is a derivative in W, so it is evaluated with the body
rates rotated into W: ``a' = j + (R(q) α) × v + (R(q) ω) × a``. The noises are the jerk ``j``
(m/s^3), the angular acceleration ``α`` (rad/s^2) and the bias drift ``b̄`` (m/s^3), held
constant over each step with the paper's standard deviations 15, 15 and 1e-3 (discrete: the
process noise therefore depends on the step, as the paper's).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from humimic.estimation.ekf import quaternion as qj
from humimic.maths.kinematics import ca_predict
from humimic.motion import quat

#: Slices of the 19-number interface state.
P, Q, V, W, A, B = (slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13), slice(13, 16),
                    slice(16, 19))
DIM = 19
#: Sugiyama sec. III-A: sigma of the jerk (m/s^3), angular acceleration (rad/s^2), bias drift.
SIGMA_JERK, SIGMA_ALPHA, SIGMA_BIAS = 15.0, 15.0, 1e-3
#: Sugiyama sec. III-B: sigma of the orientation (quaternion components) and acceleration.
SIGMA_ORIENTATION, SIGMA_ACCEL = 1e-3, 0.5


@dataclass(frozen=True)
class MotionNoise:
    """Standard deviations of the three system noises (Sugiyama sec. III-A)."""

    jerk: float = SIGMA_JERK
    alpha: float = SIGMA_ALPHA
    bias: float = SIGMA_BIAS

    def covariance(self) -> np.ndarray:
        """``diag(σ_j^2 I, σ_α^2 I, σ_b^2 I)`` (9x9), noise order ``(j, α, b̄)``."""
        return np.diag(self.variances())

    def variances(self) -> np.ndarray:
        """The diagonal of :meth:`covariance` (9,)."""
        return np.repeat([self.jerk**2, self.alpha**2, self.bias**2], 3)


def initial_state(p=(0, 0, 0), q=(1, 0, 0, 0), v=(0, 0, 0), w=(0, 0, 0), a=(0, 0, 0),
                  b=(0, 0, 0)) -> np.ndarray:
    """A 19-number interface state from its parts (defaults: at rest at the origin)."""
    return np.concatenate([p, q, v, w, a, b]).astype(float)


def _skew(v) -> np.ndarray:
    """``[v]x`` of one 3-vector (a list or array; faster than the batched :func:`qj.skew`)."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotmat(q) -> np.ndarray:
    """``R(q)`` of one unit quaternion (the formula of :func:`humimic.motion.quat.to_matrix`,
    without its batching overhead)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _d_rotate_dq(q, v) -> np.ndarray:
    """:func:`qj.d_rotate_dq` for one vector, written out: ``d(R(q) v)/dq`` (3x4) with the
    ``w`` column ``2 u x v`` and the ``u`` block ``2 (-w [v]x + (u.v) I + u v^T - 2 v u^T)``."""
    w, a, b, c = q
    x, y, z = v
    s = a * x + b * y + c * z
    return 2.0 * np.array([
        [b * z - c * y, s - a * x, w * z + a * y - 2 * x * b, -w * y + a * z - 2 * x * c],
        [c * x - a * z, -w * z + b * x - 2 * y * a, s - b * y, w * x + b * z - 2 * y * c],
        [a * y - b * x, w * y + c * x - 2 * z * a, -w * x + c * y - 2 * z * b, s - c * z]])


@functools.lru_cache(maxsize=16)
def _skeleton(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The constant blocks of ``F`` and ``G`` for a step ``dt`` (read-only; copied per call)."""
    dt2, dt3 = dt * dt / 2.0, dt**3 / 6.0
    I3 = np.eye(3)
    F = np.eye(DIM)
    F[P, V], F[P, A], F[V, A] = dt * I3, dt2 * I3, dt * I3
    G = np.zeros((DIM, 9))
    G[P, 0:3], G[V, 0:3], G[A, 0:3] = dt3 * I3, dt2 * I3, dt * I3
    G[W, 3:6], G[B, 6:9] = dt * I3, dt * I3
    F.flags.writeable = G.flags.writeable = False
    return F, G


def _quat_increment(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``q(θ)`` and ``dq(θ)/dθ`` for one rotation vector (scalar arithmetic: IMU rate)."""
    tx, ty, tz = theta.tolist()
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if t < 1e-6:
        s, c, ds_over_t = 0.5 - t * t / 48.0, 1.0 - t * t / 8.0, -1.0 / 24.0
    else:
        s, c = math.sin(t / 2) / t, math.cos(t / 2)
        ds_over_t = (0.5 * c * t - math.sin(t / 2)) / t**3
    dq = np.array([c, s * tx, s * ty, s * tz])
    J = np.empty((4, 3))
    J[0] = -0.5 * s * theta
    J[1:] = ds_over_t * np.outer(theta, theta)
    J[1, 0] += s
    J[2, 1] += s
    J[3, 2] += s
    return dq, J


def predict(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Propagate the interface state by ``dt`` (s) with zero noise.  # Sugiyama eqs. 3-4

    Returns ``(x', F, G)``: the predicted state, ``F = dx'/dx`` (19x19) and ``G = dx'/dn``
    (19x9) for the noise ``n = (j, α, b̄)``; the process noise is ``G Q_n G^T``. (Written for
    one state with small-array arithmetic: it runs at the IMU rate.)
    """
    q = x[Q].tolist()
    v, w, a = x[V], x[W], x[A]
    dt2, dt3 = dt * dt / 2.0, dt**3 / 6.0
    Rq = rotmat(q)
    w_W = Rq @ w
    Sa = _skew(a.tolist())
    da = -(Sa @ w_W)  # (R(q) ω) × a, eq. 4 mean
    dq, dq_dtheta = _quat_increment(w * dt)  # eq. 3: q(ω Δt + Δt^2/2 α), mean
    Lq = qj.left(q)
    dq_dtheta = Lq @ dq_dtheta
    p_ca, v_ca, _ = ca_predict(x[P], v, a, dt)

    out = np.empty(DIM)
    out[P] = p_ca + dt3 * da
    out[Q] = Lq @ dq
    out[V] = v_ca + dt2 * da
    out[W] = w
    out[A] = a + dt * da
    out[B] = x[B]

    F0, G0 = _skeleton(float(dt))
    F, G = F0.copy(), G0.copy()
    # d(da)/d(q, ω, a) with da = -[a]x R(q) ω, entering p, v, a with dt^3/6, dt^2/2, dt
    dda = np.empty((3, 13))  # columns as the state's 3..15: q (4), v (3, zero), ω (3), a (3)
    dda[:, 0:4] = -Sa @ _d_rotate_dq(q, w.tolist())
    dda[:, 4:7] = 0.0
    dda[:, 7:10] = -Sa @ Rq
    dda[:, 10:13] = _skew(w_W.tolist())
    F[0:3, 3:16] += dt3 * dda
    F[7:10, 3:16] += dt2 * dda
    F[13:16, 3:16] += dt * dda
    F[Q, Q] = qj.right(dq)
    F[Q, W] = dq_dtheta * dt

    # Noise: a' = j + (R α) × v + ...; θ += α Δt^2/2; ω += α Δt; b += b̄ Δt.
    dda_dalpha = -_skew(v.tolist()) @ Rq
    G[P, 3:6] = dt3 * dda_dalpha
    G[V, 3:6] = dt2 * dda_dalpha
    G[A, 3:6] = dt * dda_dalpha
    G[Q, 3:6] = dq_dtheta * dt2
    return out, F, G


def process_noise(G: np.ndarray, noise: MotionNoise) -> np.ndarray:
    """``G Q_n G^T`` (19x19) for the noise Jacobian ``G`` of :func:`predict`."""
    return (G * _variances(noise)) @ G.T


@functools.lru_cache(maxsize=8)
def _variances(noise: MotionNoise) -> np.ndarray:
    v = noise.variances()
    v.flags.writeable = False
    return v


# ---- inertial measurement models (Sugiyama eqs. 6-7) --------------------------------------

#: Columns of the state each inertial measurement reads.
ORIENTATION_COLS = np.arange(3, 7)
ACCEL_COLS = np.arange(13, 19)
#: ``H`` of eq. 6 on ``ORIENTATION_COLS`` and of eq. 7 on ``ACCEL_COLS``.
H_ORIENTATION = np.eye(4)
H_ACCEL = np.hstack([np.eye(3), np.eye(3)])


def h_orientation(x: np.ndarray) -> np.ndarray:
    """``h_q = q``.  # Sugiyama eq. 6"""
    return x[Q].copy()


def h_accel(x: np.ndarray) -> np.ndarray:
    """``h_a = a + b`` (in W).  # Sugiyama eq. 7"""
    return x[A] + x[B]


def world_acceleration(f_I: np.ndarray, R_WI: np.ndarray, g_W: np.ndarray) -> np.ndarray:
    """The measured acceleration in W that eq. 7 compares with: ``R_WI f_I + g_W`` for the
    accelerometer's specific force ``f_I`` (gravity included, as read), the measured
    orientation ``R_WI`` and gravity ``g_W``."""
    return R_WI @ f_I + g_W


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``[w, x, y, z]`` (``w >= 0``) of one rotation matrix (Shepperd's method
    as :func:`humimic.motion.quat.from_matrix`, scalar: it runs at the IMU rate)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = R.tolist()
    tr = m00 + m11 + m22
    if tr >= max(m00, m11, m22):
        q = (1.0 + tr, m21 - m12, m02 - m20, m10 - m01)
    elif m00 >= m11 and m00 >= m22:
        q = (m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20)
    elif m11 >= m22:
        q = (m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21)
    else:
        q = (m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22)
    out = np.array(q)
    out /= math.copysign(math.sqrt(float(out @ out)), out[0])
    return out
