"""Particle filters as pure functions, vectorised over particles (Menezes et al. sec. 3).

A particle set is ``(particles (N, d), log_weights (N,))`` with normalised log-weights. A
measurement enters as ``log_likelihood(x (n, d)) -> (n,)``, the log of ``p(z_k|x)`` up to a
constant (the cues of :mod:`humimic.perception.cues` for this frame). Randomness comes from the
``numpy.random.Generator`` passed in. Every step returns a :class:`Step`: the new set, the
MMSE estimate of the weighted set (Table 1 step 7, before any resampling), and
``log_evidence``, the estimate of ``log p(z_k | z_{1:k-1})`` (its sum over ``k`` is the
marginal log-likelihood; each increment is unbiased on the linear scale).

When every particle has zero likelihood, ``ok`` is False, ``log_evidence`` is ``-inf``, and
the set is the proposed particles with uniform weights: finite, never NaN; the caller decides
whether to re-initialise (:func:`initialize` from a prior or an importance function).

Filters
-------
* :func:`sir_step` -- SIR, Table 1: ``x_k ~ q(x|x_{k-1}, z_k)``, weight ratio
  ``p(z|x) p(x|x_{k-1}) / q(x|x_{k-1}, z)``; resampling when the effective sample size falls
  below ``resample_below * N`` (step 8's "efficiency criterion").
* :func:`condensation_step` -- CONDENSATION (sec. 3.2): ``q`` = the dynamics, resampling on every
  cycle.
* :func:`icondensation_step` -- ICONDENSATION with the mixed proposal of sec. 3.2; weights below.
* :func:`apf_step` -- the auxiliary particle filter, Table 2.

ICONDENSATION's importance weights
----------------------------------
With probability ``alpha`` a particle is drawn from the importance function ``pi(x|z_k)``,
with ``beta`` from the dynamics, and with ``gamma = 1 - alpha - beta`` from the prior
``p0(x)``. Drawing "from the dynamics" means picking a predecessor ``j`` with probability
``w_{k-1}^j`` and sampling ``p(x|x_{k-1}^j)``, i.e. sampling the predicted density

    f(x) = sum_j w_{k-1}^j p(x | x_{k-1}^j)            (the filter's prior at time k).

Each new particle is therefore an independent draw from the mixture

    q(x) = alpha pi(x|z_k) + beta f(x) + gamma p0(x),

whatever component produced it. The filtering target is ``p(x_k|z_{1:k}) ∝ p(z_k|x) f(x)``
(the Chapman-Kolmogorov prediction of the particle approximation, then Bayes), so
importance sampling gives the weights

    w_k^i ∝ p(z_k | x^i) f(x^i) / q(x^i),

and ``(1/N) sum_i p(z_k|x^i) f(x^i) / q(x^i)`` is an unbiased estimate of
``p(z_k|z_{1:k-1})``. The denominator is the *whole* mixture, not the density of the component
that drew the particle: weighting a ``pi``-drawn particle by ``f/pi`` and a dynamics-drawn one
by 1 (Isard & Blake's shortcut) is biased unless the two densities coincide. The numerator
``f`` sums over every predecessor (N x N transition densities), so a particle the detector
proposes is weighted by how well it continues *any* hypothesis, not one arbitrary ancestor --
the per-ancestor form ``p(z|x) p(x|x_{k-1}^i) / q(x|x_{k-1}^i, z)`` of Table 1 step 5 is also
consistent but gives ``pi``-drawn particles next to no weight unless their random ancestor
happens to be near. Particles proposed far from every hypothesis (a target that re-appears
elsewhere) keep a weight only if the dynamics give that event probability: use
:class:`~humimic.estimation.particles.densities.Resetting` dynamics for trackers that must
re-initialise. Without an importance function (no detection) ``alpha`` is 0 and ``beta``,
``gamma`` are scaled up in proportion. No resampling is needed: the dynamics component already
selects predecessors by weight.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from humimic.estimation.particles.densities import Density, Dynamics, pairwise_log_density
from humimic.estimation.particles.resampling import (
    Method,
    indices_from_weights,
    resample_indices,
)
from humimic.estimation.particles.weights import (
    ess_of_weights,
    logsumexp,
    mean_of_weights,
    normalize,
    uniform_log_weights,
    weights,
)

LogLikelihood = Callable[[np.ndarray], np.ndarray]


class Step(NamedTuple):
    particles: np.ndarray
    """``(N, d)`` after the step (resampled if ``resampled``)."""
    log_weights: np.ndarray
    """``(N,)`` normalised."""
    mean: np.ndarray
    """MMSE estimate of the weighted set before resampling (Table 1 step 7)."""
    log_evidence: float
    """Estimate of ``log p(z_k | z_{1:k-1})``; ``-inf`` when ``ok`` is False."""
    ess: float
    """Effective sample size of the weighted set before resampling."""
    ok: bool
    """False when every particle had zero likelihood (weights then uniform)."""
    resampled: bool


def initialize(prior: Density, n: int, rng: np.random.Generator) -> tuple[np.ndarray,
                                                                          np.ndarray]:
    """``n`` particles i.i.d. from ``prior`` with uniform weights (Table 1 step 1)."""
    if n <= 0:
        raise ValueError(f"number of particles must be > 0, got {n}")
    return np.asarray(prior.sample(n, rng), float), uniform_log_weights(n)


def predict(particles: np.ndarray, dynamics: Dynamics, rng: np.random.Generator) -> np.ndarray:
    """Propagate every particle through the dynamics: ``x_k ~ p(x_k | x_{k-1})``."""
    return dynamics.sample(np.asarray(particles, float), rng)


def update(log_weights: np.ndarray, log_increment: np.ndarray) -> tuple[np.ndarray, float,
                                                                       bool]:
    """Multiply weights by the incremental weights (in logs) and normalise.

    Returns ``(log_weights, log_evidence, ok)``; ``log_evidence = log sum_i w_i exp(inc_i)``
    (with normalised input weights: the estimate of ``log p(z_k|z_{1:k-1})``). All-zero
    weights give ``ok`` False, evidence ``-inf`` and uniform weights.
    """
    lw = np.asarray(log_weights, float) + np.asarray(log_increment, float)
    lw = np.where(np.isnan(lw), -np.inf, lw)
    norm = normalize(lw)
    return norm.log_weights, norm.log_total, norm.ok


def resample(particles: np.ndarray, log_weights: np.ndarray, rng: np.random.Generator,
             method: Method = "systematic") -> tuple[np.ndarray, np.ndarray]:
    """Equally weighted set drawn from the weighted one (Table 1 step 8)."""
    return resample_weights(particles, weights(log_weights), rng, method)


def resample_weights(particles: np.ndarray, w: np.ndarray, rng: np.random.Generator,
                     method: Method = "systematic") -> tuple[np.ndarray, np.ndarray]:
    """:func:`resample` with linear weights already from
    :func:`~humimic.estimation.particles.weights.weights` (the same draws)."""
    idx = indices_from_weights(w, rng, method)
    return np.asarray(particles)[idx], uniform_log_weights(len(idx))


def _finish(x: np.ndarray, lw: np.ndarray, evidence: float, ok: bool,
            rng: np.random.Generator, resample_below: float, method: Method) -> Step:
    w = weights(lw)                     # once for the mean, the ESS and the resampling
    mean = mean_of_weights(x, w)
    ess = ess_of_weights(w)
    if ok and ess < resample_below * len(x):
        x, lw = resample_weights(x, w, rng, method)
        return Step(x, lw, mean, evidence, ess, ok, True)
    return Step(x, lw, mean, evidence, ess, ok, False)


def sir_step(particles: np.ndarray, log_weights: np.ndarray, dynamics: Dynamics,
             log_likelihood: LogLikelihood, rng: np.random.Generator,
             proposal: Dynamics | None = None, resample_below: float = 0.5,
             method: Method = "systematic") -> Step:
    """One cycle of the generic particle filter, Menezes Table 1.

    ``proposal`` is ``q(x_k|x_{k-1}, z_k)`` (same interface as the dynamics; build it for this
    frame); None uses the dynamics (bootstrap filter, weight ratio 1). Resamples when the
    effective sample size is below ``resample_below * N`` (1.0: every cycle; 0: never).
    """
    x_prev = np.asarray(particles, float)
    if proposal is None:
        x = dynamics.sample(x_prev, rng)
        inc = log_likelihood(x)
    else:
        x = proposal.sample(x_prev, rng)
        inc = (log_likelihood(x) + dynamics.log_density(x, x_prev)
               - proposal.log_density(x, x_prev))  # Table 1 step 5
    lw, evidence, ok = update(log_weights, inc)
    return _finish(x, lw, evidence, ok, rng, resample_below, method)


def condensation_step(particles: np.ndarray, log_weights: np.ndarray, dynamics: Dynamics,
                      log_likelihood: LogLikelihood, rng: np.random.Generator,
                      method: Method = "systematic") -> Step:
    """CONDENSATION (Isard & Blake 1998): propagate through the dynamics, weight by the
    likelihood, resample every cycle."""
    return sir_step(particles, log_weights, dynamics, log_likelihood, rng, None, math.inf,
                    method)


def mixture_counts(n: int, alpha: float, beta: float, has_importance: bool,
                   rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """How many of ``n`` particles come from (importance, dynamics, prior), and the mixture
    coefficients actually used (``alpha`` is 0 without an importance function)."""
    if not (0.0 <= alpha and 0.0 <= beta and alpha + beta <= 1.0 + 1e-12):
        raise ValueError(f"need alpha, beta >= 0 and alpha + beta <= 1, got {alpha}, {beta}")
    c = np.array([alpha, beta, max(0.0, 1.0 - alpha - beta)])
    if not has_importance:
        c[0] = 0.0
    if c.sum() <= 0.0:
        c = np.array([0.0, 1.0, 0.0])
    c = c / c.sum()
    return rng.multinomial(n, c), c


def predictive_log_density(x: np.ndarray, particles: np.ndarray, log_weights: np.ndarray,
                           dynamics: Dynamics) -> np.ndarray:
    """``log f(x) = log sum_j w_j p(x | x_j)`` for every row of ``x`` (an ``(n, N)`` table;
    normalised ``log_weights``). A dynamics may shortcut it (``predictive_log_density``)."""
    own = getattr(dynamics, "predictive_log_density", None)
    if own is not None:
        return own(x, particles, log_weights)
    table = pairwise_log_density(dynamics, x, particles) + log_weights[None, :]
    m = table.max(axis=1)
    safe = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(m),
                        safe + np.log(np.exp(table - safe[:, None]).sum(axis=1)), m)


def icondensation_step(particles: np.ndarray, log_weights: np.ndarray, dynamics: Dynamics,
                       log_likelihood: LogLikelihood, rng: np.random.Generator,
                       importance: Density | None, prior: Density, alpha: float = 0.3,
                       beta: float = 0.6, method: Method = "systematic") -> Step:
    """ICONDENSATION with the mixed proposal ``alpha pi + beta f + (1 - alpha - beta) p0``
    and the importance weights derived in the module docstring (Menezes sec. 3.2; defaults
    from Tables 4-5). ``importance`` None or empty (no detection) drops the ``pi`` part."""
    x_prev = np.asarray(particles, float)
    lw_prev = normalize(log_weights).log_weights
    n = len(x_prev)
    has_pi = importance is not None and not getattr(importance, "empty", False)
    (n_pi, n_dyn, n_p0), c = mixture_counts(n, alpha, beta, has_pi, rng)
    parts = []
    if n_pi:
        parts.append(np.asarray(importance.sample(int(n_pi), rng), float))
    if n_dyn:
        anc = resample_indices(lw_prev, rng, method, int(n_dyn))
        parts.append(dynamics.sample(x_prev[anc], rng))
    if n_p0:
        parts.append(np.asarray(prior.sample(int(n_p0), rng), float))
    x = np.concatenate(parts)
    log_f = predictive_log_density(x, x_prev, lw_prev, dynamics)
    with np.errstate(divide="ignore"):
        terms = [np.log(c[1]) + log_f]
        if c[0] > 0:
            terms.append(np.log(c[0]) + importance.log_density(x))
        if c[2] > 0:
            terms.append(np.log(c[2]) + prior.log_density(x))
    log_q = np.logaddexp.reduce(np.stack(terms), axis=0)
    inc = log_likelihood(x) + log_f - log_q
    lw, total, ok = update(uniform_log_weights(n), inc)
    return _finish(x, lw, total, ok, rng, 0.0, method)


def apf_step(particles: np.ndarray, log_weights: np.ndarray, dynamics: Dynamics,
             log_likelihood: LogLikelihood, rng: np.random.Generator,
             resample_below: float = math.inf, method: Method = "systematic",
             first_stage: LogLikelihood | None = None) -> Step:
    """The auxiliary particle filter (Pitt & Shephard 1999), Menezes Table 2.

    First stage: ``lambda_i ∝ w_{k-1}^i p(z_k|mu_i)`` with ``mu_i = E[x_k|x_{k-1}^i]``;
    predecessors are resampled by ``lambda``, propagated through the dynamics, and weighted
    by ``p(z_k|x_k) / p(z_k|mu_{s(i)})``. The evidence estimate is
    ``sum_i w_i p(z|mu_i) * (1/N) sum_i p(z|x_i)/p(z|mu_{s(i)})``. If no ``mu`` has any
    likelihood the first stage falls back to the old weights (a plain SIR cycle). Resamples
    the result every cycle by default (the second bootstrap of Table 2).

    ``first_stage`` (default: ``log_likelihood``) is the function the auxiliary weights use,
    ``lambda_i ∝ w_{k-1}^i g(mu_i)``; any positive ``g`` gives a consistent filter when the
    second stage divides it out, ``p(z_k|x_k) / g(mu_{s(i)})`` (Menezes' two-arm tracker uses
    a cheap skin cue in the first stage, the full likelihood in the second).
    """
    x_prev = np.asarray(particles, float)
    lw_prev = normalize(log_weights).log_weights
    n = len(x_prev)
    log_mu_lik = np.asarray((first_stage or log_likelihood)(dynamics.mean(x_prev)), float)
    log_mu_lik = np.where(np.isnan(log_mu_lik), -np.inf, log_mu_lik)
    first = lw_prev + log_mu_lik
    first_total = logsumexp(first)
    if not np.isfinite(first_total):  # no hint from the auxiliary variables
        first, first_total, log_mu_lik = lw_prev, 0.0, np.zeros(n)
    anc = resample_indices(first, rng, method)
    x = dynamics.sample(x_prev[anc], rng)
    inc = log_likelihood(x) - log_mu_lik[anc]
    lw, second_total, ok = update(uniform_log_weights(n), inc)
    evidence = first_total + second_total if ok else -np.inf
    return _finish(x, lw, evidence, ok, rng, resample_below, method)
