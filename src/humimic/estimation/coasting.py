"""What the random-jerk filter does with an implausible measurement and without any.

Two additions to Ude & Atkeson's filter (:mod:`humimic.estimation.random_jerk`), both pure
functions here, used by :class:`~humimic.estimation.random_jerk.RandomJerkFilter`:

* **Innovation gate** (Bar-Shalom, Li & Kirubarajan 2001, *Estimation with Applications to
  Tracking and Navigation*, sec. 5.4: the normalised innovation squared and its chi-square
  test; used as a validation gate as in Bar-Shalom & Fortmann 1988, ch. 2): a measurement
  whose normalised innovation squared ``d^2 = nu^T S^-1 nu`` (``nu = z - H x-``,
  ``S = H P- H^T + R``) exceeds the chi-square quantile of probability ``P_G`` with 3 degrees
  of freedom is rejected: under the filter's own model it would occur with probability
  ``1 - P_G``. The gate probability is ``filter.gate_probability``.

* **Damped coasting prediction**: between measurements the random-jerk model keeps the last
  acceleration for ever, so a frame predicted without a measurement extrapolates a quadratic --
  0.2 s after a few bad measurements (5 m/s, 45 m/s^2) that is 1-2 m away. A hand lives in a
  bounded workspace and its acceleration is short-correlated, so a frame without a measurement
  is predicted with a mean-reverting model instead: the acceleration a first-order Markov
  process of time constant ``tau_a`` (Singer 1970, "Estimating optimal tracking filter
  performance for manned maneuvering targets", IEEE Trans. AES 6(4)) and the velocity
  decaying with time constant ``tau_v`` (an integrated Ornstein-Uhlenbeck velocity), driven by
  the same white jerk of density ``b^2``::

      d/dt [p, v, a] = F [p, v, a] + [0, 0, phi],
      F = [[0, I, 0], [0, -I/tau_v, I], [0, 0, -I/tau_a]]

  Its transition is ``expm(F dt)`` and its process noise Van Loan's (1978) integral
  ``Q = int_0^dt e^{Fs} G b^2 G^T e^{F^T s} ds``; for ``tau_v, tau_a -> inf`` both become Ude's
  eqs. 15 and 17. The mean moves at most ``~|v| tau_v + |a| tau_a tau_v`` from where the last
  measurement left it, however long the coast.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.linalg
from scipy.stats import chi2

_I3 = np.eye(3)


def gate_threshold(probability: float, dof: int = 3) -> float:
    """The chi-square gate ``gamma`` with ``P(chi2_dof <= gamma) = probability``.
    # Bar-Shalom et al. 2001, sec. 5.4 (chi-square test of the NIS)"""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"gate probability must be in (0, 1), got {probability!r}")
    return float(chi2.ppf(probability, dof))


def innovation_nis(nu: np.ndarray, S: np.ndarray) -> float:
    """Normalised innovation squared ``d^2 = nu^T S^-1 nu``.  # Bar-Shalom et al. 2001, sec. 5.4"""
    nu = np.asarray(nu, float)
    return float(nu @ np.linalg.solve(np.asarray(S, float), nu))


def _axis_dynamics(tau_v: float, tau_a: float) -> np.ndarray:
    """The per-axis drift matrix F (3x3, state [p, v, a]) of the damped model."""
    return np.array([[0.0, 1.0, 0.0], [0.0, -1.0 / tau_v, 1.0], [0.0, 0.0, -1.0 / tau_a]])


@functools.lru_cache(maxsize=64)
def damped_model(dt: float, b: float, tau_v: float, tau_a: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Transition ``A = expm(F dt)`` and process noise ``Q`` (9x9 each, state ``[p, v, a]``
    ordered as :mod:`~humimic.estimation.random_jerk`) of the damped coasting model.
    # Singer 1970 (a Markov acceleration), with a damped velocity; Q by Van Loan 1978:
    # expm([[-F, G b^2 G^T], [0, F^T]] dt) = [[., A^-1 Q], [0, A^T]]"""
    if not (dt >= 0.0 and b > 0.0 and tau_v > 0.0 and tau_a > 0.0):
        raise ValueError(f"need dt >= 0 and b, tau_v, tau_a > 0, got {dt, b, tau_v, tau_a}")
    F = _axis_dynamics(tau_v, tau_a)
    M = np.zeros((6, 6))
    M[:3, :3] = -F
    M[2, 5] = b * b  # G b^2 G^T with G = [0, 0, 1]^T: the jerk drives the acceleration
    M[3:, 3:] = F.T
    # Van Loan's -F block grows as e^{dt/tau}: take it over dt / 2^k <= min(tau), then double
    # (A(2h) = A(h)^2, Q(2h) = A(h) Q(h) A(h)^T + Q(h))
    k = max(0, math.ceil(math.log2(dt / min(tau_v, tau_a)))) if dt > 0.0 else 0
    E = scipy.linalg.expm(M * (dt / 2**k))
    A1 = E[3:, 3:].T
    Q1 = A1 @ E[:3, 3:]
    for _ in range(k):
        Q1 = A1 @ Q1 @ A1.T + Q1
        A1 = A1 @ A1
    A, Q = np.kron(A1, _I3), np.kron(0.5 * (Q1 + Q1.T), _I3)
    A.flags.writeable = Q.flags.writeable = False
    return A, Q


def coast_predict(x: np.ndarray, P: np.ndarray, dt: float, b: float, tau_v: float,
                  tau_a: float) -> tuple[np.ndarray, np.ndarray]:
    """Propagate ``(x, P)`` by ``dt`` with the damped model: ``x' = A x``, ``P' = A P A^T + Q``."""
    A, Q = damped_model(float(dt), float(b), float(tau_v), float(tau_a))
    P_new = A @ np.asarray(P, float) @ A.T + Q
    return np.asarray(x, float) @ A.T, 0.5 * (P_new + P_new.T)
