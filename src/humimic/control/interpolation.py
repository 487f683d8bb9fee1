"""Cartesian PD interpolation from the vision rate (30/60 Hz) to the servo rate (420 Hz).

Ude & Atkeson, "Generation of humanoid motion from human motion": "We employ a simple PD
controller in Cartesian space to generate in between points on the trajectory (positions,
velocities and accelerations) and thus account for the differences in the vision frame rate and
the robot servo rate." The commanded point ``(p, v)`` is driven towards the reference
``(p_r, v_r, a_r)`` by

    a = a_r + kd (v_r - v) + kp (p_r - p),      kp = omega^2, kd = 2 zeta omega

integrated exactly over each servo period (the reference held over the period). With the
estimate's own acceleration as a feed-forward the error obeys ``e'' + kd e' + kp e = 0``: a
smooth reference is followed with no lag, and the jumps at each new estimate are smoothed over
~ 4 / omega seconds.

The reference is the latest filtered estimate ``(p, v, a)`` of photon time ``t_i``:

* ``hold`` (the paper): as received;
* ``extrapolate``: predicted to the current time ``t`` with the random-jerk model's state
  transition, Ude eq. (15), ``x(t) = A(t, t_i) x(t_i)``
  (:func:`humimic.maths.kinematics.ca_predict`) - this cancels the vision latency and the hold
  between frames.

An estimate older than ``max_age`` is treated as lost: the reference stops where it was last
seen (position only), so a stale velocity is never extrapolated far.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from humimic.maths.kinematics import ca_predict


def pd_gains(omega: float, zeta: float) -> tuple[float, float]:
    """``(kp, kd)`` of a second-order system with natural frequency ``omega`` (rad/s)."""
    return omega * omega, 2.0 * zeta * omega


def pd_discretize(kp: float, kd: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretization of the PD over one servo period.

    With ``x = (p, v)`` and the reference held over the step, ``x' = A x + B u`` with
    ``A = [[0, 1], [-kp, -kd]]``, ``B = [0, 1]^T`` and ``u = a_r + kd v_r + kp p_r``, so
    ``x(t + dt) = Phi x(t) + Gamma u`` with ``Phi = exp(A dt)`` and
    ``Gamma = int_0^dt exp(A s) ds B`` (both from one matrix exponential, Van Loan's trick).
    """
    M = np.zeros((3, 3))
    M[:2, :2] = [[0.0, 1.0], [-kp, -kd]]
    M[1, 2] = 1.0
    E = expm(M * dt)
    return E[:2, :2].copy(), E[:2, 2].copy()


def pd_step(p: np.ndarray, v: np.ndarray, p_ref: np.ndarray, v_ref: np.ndarray,
            a_ref: np.ndarray, kp: float, kd: float, Phi: np.ndarray,
            Gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One servo step of the Cartesian PD (Ude, in-between points), exact for a reference held
    over the step (:func:`pd_discretize`): returns ``(p, v)`` at ``t + dt`` and the
    acceleration at ``t``."""
    (f00, f01), (f10, f11) = Phi.tolist()
    g0, g1 = Gamma.tolist()
    u = a_ref + kd * v_ref + kp * p_ref
    a = u - kd * v - kp * p
    return f00 * p + f01 * v + g0 * u, f10 * p + f11 * v + g1 * u, a


def reference(p: np.ndarray, v: np.ndarray, a: np.ndarray, age: float, mode: str,
              max_age: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The PD's reference from an estimate ``age`` seconds old (see the module docstring)."""
    if age > max_age:
        zero = np.zeros(3)
        if mode == "extrapolate":
            p, _, _ = ca_predict(p, v, a, max_age)
        return p, zero, zero
    if mode == "extrapolate":
        return ca_predict(p, v, a, age)
    return p, v, a


class CartesianInterpolator:
    """The PD state of one target; :meth:`step` once per servo tick."""

    def __init__(self, omega: float, zeta: float, dt: float, mode: str,
                 max_age: float = 0.25, feedforward: str = "acceleration"):
        self.kp, self.kd = pd_gains(omega, zeta)
        #: Which of the reference's derivatives drive the PD besides its position.
        self.use_v = feedforward in ("velocity", "acceleration")
        self.use_a = feedforward == "acceleration"
        self.Phi, self.Gamma = pd_discretize(self.kp, self.kd, dt)
        self.dt, self.mode, self.max_age = dt, mode, max_age
        self.p: np.ndarray | None = None
        self.v = np.zeros(3)
        self.a = np.zeros(3)

    @property
    def started(self) -> bool:
        return self.p is not None

    def start(self, p: np.ndarray, v: np.ndarray, a: np.ndarray, age: float) -> None:
        """Begin on the reference itself (no transient)."""
        p, v, a = reference(p, v, a, age, self.mode, self.max_age)
        self.p, self.v, self.a = p.copy(), v.copy(), a.copy()

    def step(self, p_est: np.ndarray, v_est: np.ndarray, a_est: np.ndarray,
             age: float) -> np.ndarray:
        """Advance one servo period from ``t`` to ``t + dt``, the estimate being ``age``
        seconds old at ``t``; returns the new position. The reference is held over the period
        at its value for the period's middle (``age + dt / 2``), which makes the exact ZOH step
        second-order accurate for a moving (extrapolated) reference."""
        p_ref, v_ref, a_ref = reference(p_est, v_est, a_est, age + 0.5 * self.dt, self.mode,
                                        self.max_age)
        if not self.use_a:
            a_ref = 0.0 * a_ref
            if not self.use_v:
                v_ref = 0.0 * v_ref
        self.p, self.v, self.a = pd_step(self.p, self.v, p_ref, v_ref, a_ref, self.kp, self.kd,
                                         self.Phi, self.Gamma)
        return self.p
