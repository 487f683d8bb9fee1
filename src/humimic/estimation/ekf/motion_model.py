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
    bias: float | tuple[float, float, float] = SIGMA_BIAS
    """One for every axis of W, or one per axis."""

    def covariance(self) -> np.ndarray:
        """``diag(σ_j^2 I, σ_α^2 I, σ_b^2 I)`` (9x9), noise order ``(j, α, b̄)``."""
        return np.diag(self.variances())

    def variances(self) -> np.ndarray:
        """The diagonal of :meth:`covariance` (9,)."""
        return np.r_[np.full(3, self.jerk**2), np.full(3, self.alpha**2),
                     np.broadcast_to(np.square(self.bias), (3,))]


def initial_state(p=(0, 0, 0), q=(1, 0, 0, 0), v=(0, 0, 0), w=(0, 0, 0), a=(0, 0, 0),
                  b=(0, 0, 0)) -> np.ndarray:
    """A 19-number interface state from its parts (defaults: at rest at the origin)."""
    return np.concatenate([p, q, v, w, a, b]).astype(float)


def rotmat(q) -> np.ndarray:
    """``R(q)`` of one unit quaternion (the formula of :func:`humimic.motion.quat.to_matrix`,
    without its batching overhead)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@functools.lru_cache(maxsize=16)
def _layout(dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For a step ``dt``: the constant parts of ``F`` and ``G`` and, for the entries that
    depend on the state, their flat indices and constant parts (read-only)."""
    dt2, dt3 = dt * dt / 2.0, dt**3 / 6.0
    I3 = np.eye(3)
    F = np.eye(DIM)
    F[P, V], F[P, A], F[V, A] = dt * I3, dt2 * I3, dt * I3
    G = np.zeros((DIM, 9))
    G[P, 0:3], G[V, 0:3], G[A, 0:3] = dt3 * I3, dt2 * I3, dt * I3
    G[W, 3:6], G[B, 6:9] = dt * I3, dt * I3
    # variable entries of F, in the order predict() lists them: rows p, v, a (3 each) x
    # columns q (4), ω (3), a (3); then rows q x columns q (4) and ω (3)
    rf = [(r0 + i, c) for r0 in (0, 7, 13) for i in range(3)
          for c in (*range(3, 7), *range(10, 16))]
    rf += [(r, c) for r in range(3, 7) for c in (*range(3, 7), *range(10, 13))]
    idx_f = np.array([r * DIM + c for r, c in rf])
    F_const = F.flat[idx_f].copy()
    F_const[90:][[k * 7 + k for k in range(4)]] = 0.0  # F[q, q] is replaced, not added to
    # variable entries of G: rows p, v, a, q x the α columns 3..5
    rg = [(r, c) for r in (*range(0, 3), *range(7, 10), *range(13, 16), *range(3, 7))
          for c in range(3, 6)]
    idx_g = np.array([r * 9 + c for r, c in rg])
    out = F, G, idx_f, F_const, idx_g
    for arr in out:
        arr.flags.writeable = False
    return out


def _quat_increment(tx: float, ty: float, tz: float) -> tuple[tuple, list]:
    """``q(θ)`` and ``dq(θ)/dθ`` (4x3, rows) for one rotation vector θ (rad): ``q(θ) =
    (cos(t/2), s(t) θ)``, ``s(t) = sin(t/2)/t``, ``t = |θ|``; near zero ``s ≈ 1/2 - t^2/48``."""
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if t < 1e-6:
        s, c, k = 0.5 - t * t / 48.0, 1.0 - t * t / 8.0, -1.0 / 24.0
    else:
        s, c = math.sin(t / 2) / t, math.cos(t / 2)
        k = (0.5 * c * t - math.sin(t / 2)) / t**3  # s'(t) / t
    th = (tx, ty, tz)
    J = [[-0.5 * s * v for v in th]]
    J += [[k * th[i] * th[j] + (s if i == j else 0.0) for j in range(3)] for i in range(3)]
    return (c, s * tx, s * ty, s * tz), J


def predict(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Propagate the interface state by ``dt`` (s) with zero noise.  # Sugiyama eqs. 3-4

    Returns ``(x', F, G)``: the predicted state, ``F = dx'/dx`` (19x19) and ``G = dx'/dn``
    (19x9) for the noise ``n = (j, α, b̄)``; the process noise is ``G Q_n G^T``. It runs at
    the IMU rate, so the small Jacobian blocks are computed with scalars and scattered into
    ``F`` and ``G`` in one step each (checked against finite differences of a direct
    transcription of eqs. 3-4 in ``tests/test_ekf_jacobians.py``).
    """
    qw, qx, qy, qz = q = x[Q].tolist()
    v, w, a = x[V].tolist(), x[W].tolist(), x[A].tolist()
    dt2, dt3 = dt * dt / 2.0, dt**3 / 6.0
    R = rotmat(q).tolist()
    Rc = list(zip(*R, strict=True))  # columns of R
    wW = [R[i][0] * w[0] + R[i][1] * w[1] + R[i][2] * w[2] for i in range(3)]
    da = _cross(wW, a)  # eq. 4's mean: a' = (R(q) ω) × a
    dq, Jth = _quat_increment(w[0] * dt, w[1] * dt, w[2] * dt)  # eq. 3: q ⊗ q(ω Δt)
    Lq = qj.left(q)
    p_ca, v_ca, _ = ca_predict(x[P], x[V], x[A], dt)

    out = np.empty(DIM)
    out[P] = p_ca + dt3 * np.array(da)
    out[Q] = Lq @ dq
    out[V] = v_ca + dt2 * np.array(da)
    out[W] = x[W]
    out[A] = x[A] + dt * np.array(da)
    out[B] = x[B]

    # d(a')/dq = d((R ω) × a)/dq: column j is (dRω/dq_j) × a, with dRω/dq from
    # R(q) ω = ω + 2 qw (u × ω) + 2 u × (u × ω), u = (qx, qy, qz)
    s_uw = qx * w[0] + qy * w[1] + qz * w[2]
    u_x_w = _cross((qx, qy, qz), w)
    d_rw = [  # columns of d(R ω)/dq: w, x, y, z
        tuple(2.0 * c for c in u_x_w),
        (2 * s_uw - 2 * qx * w[0], 2 * (-qw * w[2] + qy * w[0] - 2 * w[1] * qx),
         2 * (qw * w[1] + qz * w[0] - 2 * w[2] * qx)),
        (2 * (qw * w[2] + qx * w[1] - 2 * w[0] * qy), 2 * s_uw - 2 * qy * w[1],
         2 * (-qw * w[0] + qz * w[1] - 2 * w[2] * qy)),
        (2 * (-qw * w[1] + qx * w[2] - 2 * w[0] * qz),
         2 * (qw * w[0] + qy * w[2] - 2 * w[1] * qz), 2 * s_uw - 2 * qz * w[2]),
    ]
    dda_q = [_cross(col, a) for col in d_rw]  # per q column
    dda_w = [_cross(col, a) for col in Rc]  # d(a')/dω: column j is R[:, j] × a
    # d(a')/da = [R ω]x: column j is (R ω) × e_j
    dda_a = [(0.0, wW[2], -wW[1]), (-wW[2], 0.0, wW[0]), (wW[1], -wW[0], 0.0)]
    cols = dda_q + dda_w + dda_a  # 10 columns (3-vectors) for q, ω, a
    block = np.array(cols).T  # (3, 10): d(a')/d(q, ω, a)
    dqw = Lq @ np.array(Jth)  # d(q ⊗ q(θ))/dθ (4x3)
    vals = np.concatenate([np.multiply.outer(np.array([dt3, dt2, dt]), block).ravel(),
                           np.hstack([qj.right(dq), dt * dqw]).ravel()])  # d(q ⊗ dq)/dq

    F0, G0, idx_f, F_const, idx_g = _layout(float(dt))
    F, G = F0.copy(), G0.copy()
    F.flat[idx_f] = F_const + vals
    # noise α enters a' as (R α) × v: d(a')/dα has the columns R[:, j] × v
    dal = np.array([_cross(col, v) for col in Rc]).T  # (3, 3)
    G.flat[idx_g] = np.concatenate([np.multiply.outer(np.array([dt3, dt2, dt]), dal).ravel(),
                                    (dt2 * dqw).ravel()])  # θ += α Δt^2/2
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


def h_specific_force(x: np.ndarray, g_W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The accelerometer's reading in I, ``h = R(q)^T (a + b - g_W)``, and ``dh/dx`` (3x19).

    Eq. 7 in the sensor's own frame: the paper compares ``a + b`` with the reading rotated
    into W by the *measured* orientation, which makes the acceleration's error carry the
    orientation sensor's (slow) tilt error and leaves gravity no say in the estimated tilt.
    Compared in I, gravity ties the tilt to the accelerometer (``b`` stays in W).

    With ``u = (qx, qy, qz)``: ``R^T v = v - 2 qw (u × v) + 2 (u (u·v) - v |u|^2)``, so
    ``d/dqw = -2 u × v`` and ``d/du_i = -2 qw (e_i × v) + 2 (e_i (u·v) + u v_i - 2 u_i v)``
    (scalars: it runs at the IMU rate; checked against finite differences)."""
    qw, qx, qy, qz = x[Q].tolist()
    vx, vy, vz = (x[A] + x[B] - g_W).tolist()
    u, v = (qx, qy, qz), (vx, vy, vz)
    uv = qx * vx + qy * vy + qz * vz
    uxv = _cross(u, v)
    e_x_v = ((0.0, -vz, vy), (vz, 0.0, -vx), (-vy, vx, 0.0))  # e_i × v
    cols = [tuple(-2.0 * c for c in uxv)]
    for i in range(3):
        cols.append(tuple(-2.0 * qw * e_x_v[i][r] + 2.0 * ((uv if r == i else 0.0)
                                                           + u[r] * v[i] - 2.0 * u[i] * v[r])
                          for r in range(3)))
    Rt = rotmat((qw, qx, qy, qz)).T
    H = np.zeros((3, DIM))
    H[:, Q] = np.array(cols).T
    H[:, A] = Rt
    H[:, B] = Rt
    return Rt @ (x[A] + x[B] - g_W), H


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


@functools.lru_cache(maxsize=32)
def inertial_model(given: tuple[bool, ...], s_q: float, s_a: float | tuple, s_w: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``H`` on the 19 state columns and the (isotropic) noise of the inertial measurements
    ``given`` (q, a, ω) stacked in that order: eq. 6 ``h = q``, eq. 7 ``h = a + b`` and the
    angular rate ``h = ω`` (the form of the arm's eq. 15); standard deviations ``s_*``
    (``s_a`` one for all three axes, or one per axis). An optional fourth flag appends the
    specific force in I (:func:`h_specific_force`, noise ``s_a``) with zero rows in ``H``:
    that model is not linear, the caller fills them."""
    blocks = [(ORIENTATION_COLS, H_ORIENTATION, s_q), (ACCEL_COLS, H_ACCEL, s_a),
              (np.arange(10, 13), np.eye(3), s_w), (ACCEL_COLS, np.zeros((3, 6)), s_a)]
    chosen = [b for b, g in zip(blocks, (*given, False)[:4], strict=True) if g]
    H = np.zeros((sum(len(h) for _, h, _ in chosen), DIM))
    r = 0
    for cols, h, _ in chosen:
        H[r:r + h.shape[0], cols] = h
        r += h.shape[0]
    var = np.concatenate([np.broadcast_to(np.square(s), (len(h),)) for _, h, s in chosen])
    out = H, np.diag(var)
    for a in out:
        a.flags.writeable = False
    return out


def orientation_noise(q: np.ndarray, tilt: float, yaw: float, s_q: float) -> np.ndarray:
    """The 4x4 noise of eq. 6 for an orientation error of small rotations about W's
    horizontal axes (std ``tilt``, rad) and its vertical y (``yaw``): ``J diag(tilt^2, yaw^2,
    tilt^2) J^T`` with ``J = d(q(δ) ⊗ q)/dδ``, plus ``s_q^2`` along ``q`` itself."""
    J = 0.5 * qj.right(q)[:, 1:]
    var = np.array([tilt * tilt, yaw * yaw, tilt * tilt])
    return (J * var) @ J.T + s_q * s_q * np.outer(q, q)
