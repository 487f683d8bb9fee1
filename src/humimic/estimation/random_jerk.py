"""Random-jerk Kalman filter of Ude & Atkeson (eqs. 12-18).

State per target ``x = [p, v, a]`` in R^9 (metres, m/s, m/s^2, all in one frame, normally the
robot base frame), ordered ``[p_x, p_y, p_z, v_x, v_y, v_z, a_x, a_y, a_z]``.

Noise model (Ude eq. 12): the jerk ``phi(t)`` is continuous white noise with
``E[phi(t) phi(t+s)^T] = b^2 delta(s) I``. ``b^2`` is the (two-sided) power spectral density of
each jerk component, units (m/s^3)^2 / Hz = m^2 s^-5, so ``b`` has units m s^-2.5. Since ``Q``
(eq. 17) is ``b^2`` times powers of ``dt`` and its position block is a length^2, converting
lengths from mm to m divides ``Q`` by 1e6 and therefore ``b`` by 1e3: the paper's
``b = 27500 mm s^-2.5`` is :data:`B_PAPER_SI` ``= 27.5 m s^-2.5``. In filterpy's terms this is
``Q_continuous_white_noise(dim=3, dt, spectral_density=b**2, block_size=3)`` (after reordering).

Update: the Joseph form ``P+ = (I-KH) P (I-KH)^T + K R K^T`` (as filterpy), which keeps ``P``
symmetric positive semi-definite with the very large initial velocity/acceleration variances.

All pure functions broadcast over leading batch dimensions (``x: (..., 9)``, ``P: (..., 9, 9)``).
"""

from __future__ import annotations

import functools

import numpy as np

from humimic.estimation.coasting import coast_predict, innovation_nis

#: The paper's spectral amplitude, b = 27500 mm s^-2.5, in SI units (m s^-2.5).
B_PAPER_SI = 27.5
#: Initial velocity variance (m/s)^2 -- "very large" vs human hand speeds (<~3 m/s): sigma 10 m/s.
INIT_VEL_VAR = 1.0e2
#: Initial acceleration variance (m/s^2)^2 -- "very large" vs human (<~30 m/s^2): sigma 100 m/s^2.
INIT_ACC_VAR = 1.0e4

DIM = 9
_I3 = np.eye(3)
_I9 = np.eye(DIM)
#: Ude eq. 18: H = [I 0 0].
H = np.hstack([_I3, np.zeros((3, 6))])


def transition(dt: float) -> np.ndarray:
    """State transition ``A(t + dt, t)`` (9x9).  # Ude eq. 15

    The matrix form of :func:`humimic.maths.kinematics.ca_predict` (``A x`` is its
    prediction; tested): the filter needs the matrix to propagate the covariance."""
    A = np.eye(DIM)
    A[0:3, 3:6] = dt * _I3
    A[0:3, 6:9] = 0.5 * dt * dt * _I3
    A[3:6, 6:9] = dt * _I3
    return A


def process_noise(dt: float, b: float) -> np.ndarray:
    """Process-noise covariance ``Q(dt)`` (9x9) for jerk spectral amplitude ``b`` (m s^-2.5).

    Ude eq. 17 (the closed form of eqs. 12 and 16): ``b^2 * [[dt^5/20, dt^4/8, dt^3/6],
    [dt^4/8, dt^3/3, dt^2/2], [dt^3/6, dt^2/2, dt]] (x) I_3``.
    """
    d = float(dt)
    q = (b * b) * np.array(
        [
            [d**5 / 20.0, d**4 / 8.0, d**3 / 6.0],
            [d**4 / 8.0, d**3 / 3.0, d**2 / 2.0],
            [d**3 / 6.0, d**2 / 2.0, d],
        ]
    )  # Ude eq. 17
    return np.kron(q, _I3)


def _sym(P: np.ndarray) -> np.ndarray:
    return 0.5 * (P + np.swapaxes(P, -1, -2))


@functools.lru_cache(maxsize=64)
def _model(dt: float, b: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    A = transition(dt)
    for m in (A, Q := process_noise(dt, b)):
        m.flags.writeable = False
    return A, A.T, Q


def predict(x: np.ndarray, P: np.ndarray, dt: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Propagate ``(x, P)`` by ``dt`` seconds: ``x' = A x``, ``P' = A P A^T + Q``.  # Ude eq. 14"""
    A, At, Q = _model(float(dt), float(b))  # frame intervals repeat: cache A and Q
    x_new = np.asarray(x, dtype=float) @ At
    P_new = A @ np.asarray(P, dtype=float) @ At + Q
    return x_new, _sym(P_new)


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Measurement update with a 3-D position ``z`` of covariance ``R`` (3x3).  # Ude eq. 18

    Joseph form: ``K = P H^T (H P H^T + R)^-1``, ``P+ = (I-KH) P (I-KH)^T + K R K^T``.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    z = np.asarray(z, dtype=float)
    R = np.asarray(R, dtype=float)
    PHt = P[..., :, 0:3]  # P H^T
    S = P[..., 0:3, 0:3] + R  # H P H^T + R
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)  # S symmetric
    y = z - x[..., 0:3]
    x_new = x + (K @ y[..., None])[..., 0]
    IKH = np.broadcast_to(_I9, P.shape).copy()
    IKH[..., :, 0:3] -= K
    P_new = IKH @ P @ np.swapaxes(IKH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    return x_new, _sym(P_new)


def initial_state(
    z: np.ndarray, R: np.ndarray, vel_var: float = INIT_VEL_VAR, acc_var: float = INIT_ACC_VAR
) -> tuple[np.ndarray, np.ndarray]:
    """Ude's initialisation: ``p = z`` with covariance ``R``; ``v = a = 0``, large variances."""
    x = np.zeros(DIM)
    x[0:3] = z
    P = np.zeros((DIM, DIM))
    P[0:3, 0:3] = R
    P[3:6, 3:6] = vel_var * _I3
    P[6:9, 6:9] = acc_var * _I3
    return x, P


class RandomJerkFilter:
    """One target's random-jerk Kalman filter with timestamps (s) and prediction-only gaps.

    ``step(t, z, R)`` advances to time ``t`` and, if ``z`` is given, fuses it; the first measurement
    initialises the state (Ude: position and its covariance from the measurement, ``v = a = 0``
    with :data:`INIT_VEL_VAR`, :data:`INIT_ACC_VAR`). ``z=None`` is a missed frame (prediction
    only); a missed frame more than ``max_gap`` seconds after the last measurement resets the
    filter instead (counted in :attr:`resets`), to be re-initialised by the next measurement:
    extrapolating a hand for seconds is no estimate. Times must not go backwards.

    With ``coast_tau=(tau_v, tau_a)`` a frame without a fused measurement is predicted with the
    damped model of :mod:`humimic.estimation.coasting` (velocity and acceleration decaying with
    those time constants) instead of Ude's constant-acceleration extrapolation; a prediction to
    a measured frame is always Ude's. With ``gate`` (a chi-square threshold, see
    :func:`~humimic.estimation.coasting.gate_threshold`) a measurement whose normalised
    innovation squared exceeds it is rejected (counted in :attr:`gated`) and the frame coasts;
    the ``reinit_after``-th consecutive rejection, or one more than ``max_gap`` after the last
    fused measurement, re-initialises the filter from that measurement instead (counted in
    :attr:`reinits`): a target that really moved is re-acquired.
    """

    def __init__(
        self, b: float = B_PAPER_SI, vel_var: float = INIT_VEL_VAR, acc_var: float = INIT_ACC_VAR,
        max_gap: float = np.inf, coast_tau: tuple[float, float] | None = None,
        gate: float | None = None, reinit_after: int = 3,
    ) -> None:
        if not (b > 0.0 and np.isfinite(b)):
            raise ValueError(f"spectral amplitude b must be positive and finite, got {b!r}")
        self.b = float(b)
        self.vel_var = float(vel_var)
        self.acc_var = float(acc_var)
        self.max_gap = float(max_gap)
        self.coast_tau = None if coast_tau is None else (float(coast_tau[0]), float(coast_tau[1]))
        self.gate = None if gate is None else float(gate)
        self.reinit_after = int(reinit_after)
        self.resets = 0
        """Resets after a gap longer than ``max_gap``."""
        self.gated = 0
        """Measurements rejected by the innovation gate."""
        self.reinits = 0
        """Re-initialisations from a gated measurement."""
        self.last_nis: float | None = None
        """The last measurement's normalised innovation squared (None: not gated or initial)."""
        self._rejected = 0
        self.reset()

    def reset(self) -> None:
        self._x: np.ndarray | None = None
        self._P: np.ndarray | None = None
        self._t: float | None = None
        self._t_meas = -np.inf
        self._t_init = np.inf
        self._rejected = 0

    @property
    def initialised(self) -> bool:
        return self._x is not None

    @property
    def t(self) -> float | None:
        """Time (s) the current state refers to, or None before the first measurement."""
        return self._t

    @property
    def t_measured(self) -> float:
        """Time (s) of the last fused measurement (-inf before the first)."""
        return self._t_meas

    @property
    def since_init(self) -> float:
        """Seconds from the (re)initialisation to the current time (inf before it)."""
        return np.inf if self._t is None else self._t - self._t_init

    @property
    def x(self) -> np.ndarray:
        """State ``[p, v, a]`` (copy)."""
        self._require()
        return self._x.copy()

    @property
    def P(self) -> np.ndarray:
        """State covariance 9x9 (copy)."""
        self._require()
        return self._P.copy()

    @property
    def position(self) -> np.ndarray:
        return self.x[0:3]

    @property
    def velocity(self) -> np.ndarray:
        return self.x[3:6]

    @property
    def acceleration(self) -> np.ndarray:
        return self.x[6:9]

    def _require(self) -> None:
        if self._x is None:
            raise RuntimeError("RandomJerkFilter has no state yet: call step() with a measurement")

    def _check_time(self, t: float) -> float:
        if not np.isfinite(t):
            raise ValueError(f"time must be finite, got {t!r}")
        dt = float(t) - self._t
        if dt < 0.0:
            raise ValueError(f"time went backwards: {t} < {self._t}")
        return dt

    def step(
        self, t: float, z: np.ndarray | None = None, R: np.ndarray | None = None
    ) -> np.ndarray | None:
        """Advance to ``t``, fuse ``z`` (covariance ``R``) if given; return the state (or None)."""
        if z is not None:
            z = np.asarray(z, dtype=float).reshape(3)
            R = np.asarray(R, dtype=float).reshape(3, 3)
            if not (np.isfinite(z).all() and np.isfinite(R).all()):
                raise ValueError("measurement z and covariance R must be finite")
        if z is None and self._x is not None and t - self._t_meas > self.max_gap:
            self.reset()
            self.resets += 1
        self.last_nis = None
        if self._x is None:
            if z is None:
                return None
            return self._initialise(t, z, R)
        dt = self._check_time(t)
        if z is not None:
            x, P = predict(self._x, self._P, dt, self.b) if dt > 0.0 else (self._x, self._P)
            if self.gate is not None:
                self.last_nis = innovation_nis(z - x[0:3], P[0:3, 0:3] + R)
                if self.last_nis > self.gate:  # Bar-Shalom et al. 2001, sec. 5.4
                    self.gated += 1
                    self._rejected += 1
                    if self._rejected >= self.reinit_after or t - self._t_meas > self.max_gap:
                        self.reinits += 1
                        return self._initialise(t, z, R)
                    z = None
                else:
                    self._rejected = 0
        if z is not None:
            self._x, self._P = update(x, P, z, R)
            self._t_meas = float(t)
        elif dt > 0.0:
            self._x, self._P = (predict(self._x, self._P, dt, self.b) if self.coast_tau is None
                                else coast_predict(self._x, self._P, dt, self.b, *self.coast_tau))
        self._t = float(t)
        return self._x.copy()

    def _initialise(self, t: float, z: np.ndarray, R: np.ndarray) -> np.ndarray:
        self.reset()
        self._x, self._P = initial_state(z, R, self.vel_var, self.acc_var)
        self._t = self._t_init = self._t_meas = float(t)
        return self._x.copy()

    def predict_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and covariance extrapolated to a later time ``t`` without changing the filter."""
        self._require()
        dt = self._check_time(t)
        if dt == 0.0:
            return self._x.copy(), self._P.copy()
        return predict(self._x, self._P, dt, self.b)
