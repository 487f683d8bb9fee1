"""Particle filters as a library (Menezes et al. sec. 3): SIR, CONDENSATION, ICONDENSATION and
the auxiliary particle filter as pure, vectorised step functions; resampling schemes;
log-weights; densities for priors, dynamics and importance functions; a thin stateful class.

The trackers of Menezes (hand2d, icu, gest, tbp) and Schmidt's kernel particle filter build on
these pieces; nothing here knows about images.
"""

from humimic.estimation.particles.densities import (
    Density,
    Dynamics,
    Gaussian,
    GaussianMixture,
    LinearGaussian,
    Mixture,
    RandomWalk,
    Resetting,
    UniformBox,
)
from humimic.estimation.particles.filter import KINDS, ParticleFilter
from humimic.estimation.particles.filters import (
    Step,
    apf_step,
    condensation_step,
    icondensation_step,
    initialize,
    predict,
    resample,
    sir_step,
    update,
)
from humimic.estimation.particles.resampling import METHODS, resample_indices
from humimic.estimation.particles.weights import (
    effective_sample_size,
    logsumexp,
    normalize,
    weighted_cov,
    weighted_mean,
    weights,
)

__all__ = [
    "KINDS", "METHODS", "Density", "Dynamics", "Gaussian", "GaussianMixture", "LinearGaussian",
    "Mixture", "ParticleFilter", "RandomWalk", "Resetting", "Step", "UniformBox", "apf_step",
    "condensation_step", "effective_sample_size", "icondensation_step", "initialize",
    "logsumexp", "normalize", "predict", "resample", "resample_indices", "sir_step", "update",
    "weighted_cov", "weighted_mean", "weights",
]
