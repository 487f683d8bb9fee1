"""A thin stateful wrapper around the pure steps of :mod:`.filters` (filterpy style).

    pf = ParticleFilter("icondensation", dynamics=RandomWalk([11, 6, 0.3]), prior=box, n=150)
    pf.initialize(rng)
    for frame in frames:
        step = pf.step(log_likelihood_for(frame), rng, importance=detections_for(frame))
        print(step.mean, step.ok)
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from humimic.estimation.particles import filters
from humimic.estimation.particles.densities import Density, Dynamics
from humimic.estimation.particles.resampling import METHODS, Method
from humimic.estimation.particles.weights import (
    effective_sample_size,
    weighted_cov,
    weighted_mean,
)

Kind = Literal["sir", "condensation", "icondensation", "apf"]
KINDS: tuple[str, ...] = ("sir", "condensation", "icondensation", "apf")


class ParticleFilter:
    """Particles, weights and the last step's diagnostics for one of the four filters.

    ``alpha``/``beta`` are ICONDENSATION's mixture coefficients; ``resample_below`` is SIR's
    ESS threshold (fraction of N). ``log_likelihood`` (sum of the per-frame evidences) is the
    marginal log-likelihood of the measurements so far.
    """

    def __init__(self, kind: Kind, dynamics: Dynamics, prior: Density, n: int,
                 alpha: float = 0.3, beta: float = 0.6, resample_below: float = 0.5,
                 method: Method = "systematic"):
        if kind not in KINDS:
            raise ValueError(f"unknown particle filter {kind!r}; allowed: {', '.join(KINDS)}")
        if method not in METHODS:
            raise ValueError(f"unknown resampling {method!r}; allowed: {', '.join(METHODS)}")
        if n <= 0:
            raise ValueError(f"number of particles must be > 0, got {n}")
        self.kind, self.dynamics, self.prior, self.n = kind, dynamics, prior, n
        self.alpha, self.beta = alpha, beta
        self.resample_below, self.method = resample_below, method
        self.particles: np.ndarray | None = None
        self.log_weights: np.ndarray | None = None
        self.last: filters.Step | None = None
        self.log_likelihood = 0.0

    def initialize(self, rng: np.random.Generator, source: Density | None = None) -> None:
        """Draw the particles from the prior (or from ``source``, e.g. an importance function
        after the target was lost) with uniform weights."""
        self.particles, self.log_weights = filters.initialize(source or self.prior, self.n,
                                                              rng)
        self.last = None

    def step(self, log_likelihood: filters.LogLikelihood, rng: np.random.Generator,
             importance: Density | None = None, proposal: Dynamics | None = None
             ) -> filters.Step:
        """One filter cycle for this frame's likelihood (and importance function/proposal)."""
        if self.particles is None:
            self.initialize(rng)
        args = (self.particles, self.log_weights, self.dynamics, log_likelihood, rng)
        if self.kind == "sir":
            s = filters.sir_step(*args, proposal=proposal, resample_below=self.resample_below,
                                 method=self.method)
        elif self.kind == "condensation":
            s = filters.condensation_step(*args, method=self.method)
        elif self.kind == "icondensation":
            s = filters.icondensation_step(*args, importance=importance, prior=self.prior,
                                           alpha=self.alpha, beta=self.beta,
                                           method=self.method)
        else:
            s = filters.apf_step(*args, method=self.method)
        self.particles, self.log_weights, self.last = s.particles, s.log_weights, s
        self.log_likelihood += s.log_evidence
        return s

    @property
    def mean(self) -> np.ndarray:
        """The MMSE estimate of the last step (or of the initial set)."""
        if self.last is not None:
            return self.last.mean
        return weighted_mean(self.particles, self.log_weights)

    @property
    def cov(self) -> np.ndarray:
        """Weighted covariance of the current particle set."""
        return weighted_cov(self.particles, self.log_weights)

    @property
    def ess(self) -> float:
        return effective_sample_size(self.log_weights) if self.log_weights is not None else (
            math.nan)
