"""Densities a particle filter samples from and evaluates, vectorised over particles.

Two small protocols (structural: any object with these methods works):

* :class:`Density` -- the initial prior ``p0(x)`` and importance functions ``pi(x|z)``:
  ``sample(n, rng) -> (n, d)`` and ``log_density(x (..., d)) -> (...)``.
* :class:`Dynamics` -- the state transition ``p(x_k|x_{k-1})``: ``sample(x, rng)``,
  ``log_density(x_new, x_old)`` broadcasting over leading axes (``x_new[:, None]`` against
  ``x_old[None]`` gives the ``(N, N)`` table the ICONDENSATION weights need; a dynamics may
  offer a faster ``pairwise_log_density``) and ``mean(x)`` (the auxiliary particle filter's
  ``mu_k = E[x_k|x_{k-1}]``).

Provided: :class:`Gaussian`, :class:`GaussianMixture` (the detectors' importance function,
Menezes eq. 8, with per-component weights for eq. 12), :class:`UniformBox` (a flat prior over
the image), :class:`Mixture` (eq. 9: the detectors' functions averaged), :class:`RandomWalk`
(Menezes' dynamics), :class:`LinearGaussian` (constant-velocity AR models, tests) and
:class:`Resetting` (dynamics with a small chance of re-appearing anywhere under the prior:
what makes re-initialisation from an importance function consistent with the weights).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

_LOG_2PI = math.log(2.0 * math.pi)


class Density(Protocol):
    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray: ...

    def log_density(self, x: np.ndarray) -> np.ndarray: ...


class Dynamics(Protocol):
    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray: ...

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray: ...

    def mean(self, x: np.ndarray) -> np.ndarray: ...


def _diag_gauss_logpdf(dx: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """``log N(dx; 0, diag(sigma^2))`` over the last axis."""
    z = dx / sigma
    return -0.5 * np.sum(z * z, axis=-1) - np.sum(np.log(sigma)) - 0.5 * dx.shape[-1] * _LOG_2PI


def _pairwise_sq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``|a_i - b_j|^2`` for rows of ``a (n, d)`` and ``b (m, d)``: ``(n, m)`` via one matmul."""
    d2 = np.sum(a * a, axis=1)[:, None] + np.sum(b * b, axis=1)[None, :] - 2.0 * (a @ b.T)
    return np.maximum(d2, 0.0)


@dataclass(frozen=True)
class Gaussian:
    """``N(mean, cov)`` with a full covariance."""

    mean: np.ndarray
    cov: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "mean", np.atleast_1d(np.asarray(self.mean, float)))
        cov = np.atleast_2d(np.asarray(self.cov, float))
        object.__setattr__(self, "cov", cov)
        L = np.linalg.cholesky(cov)
        object.__setattr__(self, "_L", L)
        object.__setattr__(self, "_Linv_T", np.linalg.inv(L).T)
        object.__setattr__(self, "_const", -np.sum(np.log(np.diag(L)))
                           - 0.5 * len(self.mean) * _LOG_2PI)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return self.mean + rng.standard_normal((n, len(self.mean))) @ self._L.T

    def log_density(self, x: np.ndarray) -> np.ndarray:
        z = (np.asarray(x, float) - self.mean) @ self._Linv_T
        return -0.5 * np.sum(z * z, axis=-1) + self._const


@dataclass(frozen=True)
class GaussianMixture:
    """``sum_i w_i N(x; mu_i, diag(sigma_i^2))`` -- Menezes eq. 8 (``w_i`` equal) and eq. 12
    (``w_i`` the recognition probabilities). ``means``/``sigmas`` ``(K, d)``, ``weights (K,)``
    (normalised here; zero-weight components are dropped). A mixture with no component (no
    detection) has ``empty`` True and cannot be sampled."""

    means: np.ndarray
    sigmas: np.ndarray
    weights: np.ndarray | None = None

    def __post_init__(self):
        mu = np.asarray(self.means, float)
        mu = mu[None] if mu.ndim == 1 else mu
        sig = np.broadcast_to(np.asarray(self.sigmas, float), mu.shape).copy()
        w = np.ones(len(mu)) if self.weights is None else np.asarray(self.weights, float)
        keep = w > 0
        mu, sig, w = mu[keep], sig[keep], w[keep]
        if np.any(sig <= 0):
            raise ValueError("GaussianMixture: every sigma must be > 0")
        object.__setattr__(self, "means", mu)
        object.__setattr__(self, "sigmas", sig)
        object.__setattr__(self, "weights", w / w.sum() if len(w) else w)

    @property
    def empty(self) -> bool:
        return len(self.means) == 0

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        if self.empty:
            raise ValueError("cannot sample an empty mixture (no detection)")
        k = rng.choice(len(self.means), size=n, p=self.weights)
        return self.means[k] + rng.standard_normal((n, self.means.shape[1])) * self.sigmas[k]

    def log_density(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        if self.empty:
            return np.full(x.shape[:-1], -np.inf)
        dx = x[..., None, :] - self.means  # (..., K, d)
        z = dx / self.sigmas
        comp = (-0.5 * np.sum(z * z, axis=-1) - np.sum(np.log(self.sigmas), axis=-1)
                - 0.5 * x.shape[-1] * _LOG_2PI + np.log(self.weights))
        m = comp.max(axis=-1, keepdims=True)
        return (m + np.log(np.exp(comp - m).sum(axis=-1, keepdims=True)))[..., 0]


@dataclass(frozen=True)
class UniformBox:
    """Uniform over the box ``[low, high]`` (e.g. the image and a range of scales)."""

    low: np.ndarray
    high: np.ndarray

    def __post_init__(self):
        lo, hi = np.asarray(self.low, float), np.asarray(self.high, float)
        if np.any(hi <= lo):
            raise ValueError("UniformBox: every high must exceed low")
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return self.low + rng.random((n, len(self.low))) * (self.high - self.low)

    def log_density(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        inside = np.all((x >= self.low) & (x <= self.high), axis=-1)
        return np.where(inside, -np.sum(np.log(self.high - self.low)), -np.inf)


@dataclass(frozen=True)
class Mixture:
    """``sum_j c_j p_j(x)`` of densities -- Menezes eq. 9 with ``c_j = 1/M``. Empty
    Gaussian mixtures (a detector that found nothing) are left out and the rest renormalised."""

    parts: tuple
    coefficients: tuple[float, ...] | None = None

    def __post_init__(self):
        c = np.ones(len(self.parts)) if self.coefficients is None else np.asarray(
            self.coefficients, float)
        live = [i for i, p in enumerate(self.parts) if not getattr(p, "empty", False)]
        c = c[live]
        object.__setattr__(self, "parts", tuple(self.parts[i] for i in live))
        object.__setattr__(self, "coefficients", tuple(c / c.sum()) if len(c) else ())

    @property
    def empty(self) -> bool:
        return len(self.parts) == 0

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        if self.empty:
            raise ValueError("cannot sample an empty mixture (no detection)")
        counts = rng.multinomial(n, self.coefficients)
        x = np.concatenate([p.sample(int(c), rng)
                            for p, c in zip(self.parts, counts, strict=True) if c])
        return x[rng.permutation(n)]

    def log_density(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        if self.empty:
            return np.full(x.shape[:-1], -np.inf)
        if len(self.parts) == 1:            # the sum below with one term, exactly
            return np.log(self.coefficients[0]) + self.parts[0].log_density(x)
        terms = np.stack([np.log(c) + p.log_density(x)
                          for p, c in zip(self.parts, self.coefficients, strict=True)])
        m = terms.max(axis=0)
        finite = np.isfinite(m)
        safe = np.where(finite, m, 0.0)
        return np.where(finite, safe + np.log(np.exp(terms - safe).sum(axis=0)), m)


@dataclass(frozen=True)
class RandomWalk:
    """``x_k = x_{k-1} + w``, ``w ~ N(0, diag(sigma^2))`` (Menezes secs. 5-6)."""

    sigma: np.ndarray

    def __post_init__(self):
        s = np.atleast_1d(np.asarray(self.sigma, float))
        if np.any(s <= 0):
            raise ValueError("RandomWalk: every sigma must be > 0")
        object.__setattr__(self, "sigma", s)

    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return x + rng.standard_normal(np.shape(x)) * self.sigma

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        return _diag_gauss_logpdf(np.asarray(x_new) - np.asarray(x_old), self.sigma)

    def pairwise_log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        """``log p(x_new_i | x_old_j)`` as an ``(n, N)`` table (one matrix product)."""
        d2 = _pairwise_sq(np.asarray(x_new, float) / self.sigma,
                          np.asarray(x_old, float) / self.sigma)
        return -0.5 * d2 - np.sum(np.log(self.sigma)) - 0.5 * len(self.sigma) * _LOG_2PI

    def mean(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, float)


@dataclass(frozen=True)
class LinearGaussian:
    """``x_k = F x_{k-1} + w``, ``w ~ N(0, Q)`` (constant-velocity AR models; Kalman tests)."""

    F: np.ndarray
    Q: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "F", np.atleast_2d(np.asarray(self.F, float)))
        object.__setattr__(self, "Q", np.atleast_2d(np.asarray(self.Q, float)))
        object.__setattr__(self, "_noise", Gaussian(np.zeros(len(self.Q)), self.Q))

    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return self.mean(x) + self._noise.sample(len(x), rng)

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        return self._noise.log_density(np.asarray(x_new) - self.mean(x_old))

    def pairwise_log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        """``log p(x_new_i | x_old_j)`` as an ``(n, N)`` table (one matrix product)."""
        W = self._noise._Linv_T
        d2 = _pairwise_sq(np.asarray(x_new, float) @ W, self.mean(x_old) @ W)
        return -0.5 * d2 + self._noise._const

    def mean(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, float) @ self.F.T


@dataclass(frozen=True)
class Resetting:
    """``(1 - eps) p(x_k|x_{k-1}) + eps p0(x_k)``: the target may re-appear anywhere.

    With plain dynamics a particle the importance function places far from every predecessor
    has (correctly) almost no weight; this model gives such re-appearances prior mass ``eps``.
    """

    dynamics: Dynamics
    prior: Density
    eps: float

    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        out = self.dynamics.sample(x, rng)
        reset = rng.random(len(x)) < self.eps
        if reset.any():
            out[reset] = self.prior.sample(int(reset.sum()), rng)
        return out

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        a = math.log1p(-self.eps) + self.dynamics.log_density(x_new, x_old)
        b = math.log(self.eps) + self.prior.log_density(x_new)
        return np.logaddexp(a, b)

    def pairwise_log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        a = math.log1p(-self.eps) + pairwise_log_density(self.dynamics, x_new, x_old)
        b = math.log(self.eps) + self.prior.log_density(x_new)
        return np.logaddexp(a, b[:, None])

    def predictive_log_density(self, x: np.ndarray, particles: np.ndarray,
                               log_weights: np.ndarray) -> np.ndarray:
        """``log sum_j w_j p(x|x_j) = log((1 - eps) f(x) + eps p0(x))`` with ``f`` the
        continuing dynamics' predictive density (weights normalised): O(N) beyond ``f``."""
        from humimic.estimation.particles.filters import predictive_log_density

        a = math.log1p(-self.eps) + predictive_log_density(x, particles, log_weights,
                                                           self.dynamics)
        return np.logaddexp(a, math.log(self.eps) + self.prior.log_density(x))

    def mean(self, x: np.ndarray) -> np.ndarray:
        """The continuing dynamics' mean (the auxiliary filter's point prediction)."""
        return self.dynamics.mean(x)


def pairwise_log_density(dynamics: Dynamics, x_new: np.ndarray, x_old: np.ndarray
                         ) -> np.ndarray:
    """``log p(x_new_i | x_old_j)`` ``(n, N)``: the dynamics' own fast table if it has one,
    else by broadcasting ``log_density``."""
    fast = getattr(dynamics, "pairwise_log_density", None)
    if fast is not None:
        return fast(x_new, x_old)
    return dynamics.log_density(np.asarray(x_new)[:, None, :], np.asarray(x_old)[None, :, :])


__all__ = ["Density", "Dynamics", "Gaussian", "GaussianMixture", "LinearGaussian", "Mixture",
           "RandomWalk", "Resetting", "UniformBox", "pairwise_log_density"]
