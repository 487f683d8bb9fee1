"""Deferring the map's share of interface-only EKF steps (Guivant & Nebot's compressed filter).

J. Guivant and E. Nebot, "Optimization of the simultaneous localization and map-building
algorithm for real-time implementation", IEEE T-RA 17(3), 2001. Split the state into the
interface ``a`` (19 numbers) and the map ``b``. A prediction and an inertial update touch only
``a``; done on the full state each would cost ``O(n^2)``, but their effect on ``b`` is exactly

    P_ab = Φ P_ab0,    P_bb = P_bb0 - P_ab0^T Ψ P_ab0,    x_b = x_b0 + P_ab0^T β

with ``Φ`` the product of the interface's transitions ``F`` and ``(I - K H)`` since the last
flush, ``Ψ += Φ^T H^T S^-1 H Φ`` and ``β += Φ^T H^T S^-1 ν`` per update (``Φ`` before the
update). Each IMU step then costs ``O(19^2)``; :meth:`Deferred.apply` pays ``O(n^2)`` once, before
anything reads or changes the map. Tested against the dense EKF in ``tests/test_ekf_slam.py``.
"""

from __future__ import annotations

import numpy as np


class Deferred:
    """The pending ``Φ, Ψ, β`` of a ``d``-number interface."""

    def __init__(self, d: int):
        self.d = d
        self.phi: np.ndarray | None = None
        self.psi = np.zeros((d, d))
        self.beta = np.zeros(d)

    @property
    def pending(self) -> bool:
        return self.phi is not None

    def transition(self, F: np.ndarray) -> None:
        """The interface moved linearly by ``F`` (a prediction; a renormalisation)."""
        self.phi = F if self.phi is None else F @ self.phi

    def measurement(self, H: np.ndarray, S_inv: np.ndarray, nu: np.ndarray,
                    K: np.ndarray) -> None:
        """An update of the interface by ``H`` (on its columns), ``S^-1``, innovation ``ν``
        and gain ``K`` (its interface rows)."""
        phi = np.eye(self.d) if self.phi is None else self.phi
        HPhi = H @ phi
        SiHPhi = S_inv @ HPhi
        self.psi += HPhi.T @ SiHPhi
        self.beta += SiHPhi.T @ nu
        self.phi = phi - K @ HPhi

    def apply(self, x: np.ndarray, P: np.ndarray) -> None:
        """Bring the map's mean and covariance in ``x``, ``P`` (interface first) up to date,
        in place, and start afresh."""
        if self.phi is None:
            return
        d = self.d
        if len(x) > d:
            Pab0 = P[:d, d:].copy()
            x[d:] += Pab0.T @ self.beta
            self.psi += self.psi.T  # keep it symmetric: rounding adds up over many steps
            self.psi *= 0.5
            P[d:, d:] -= Pab0.T @ (self.psi @ Pab0)
            P[:d, d:] = self.phi @ Pab0
            P[d:, :d] = P[:d, d:].T
        self.phi = None
        self.psi[...] = 0.0
        self.beta[...] = 0.0
