"""Inertial sensors: accelerometer and gyroscope noise (white noise plus a bias random walk) and
an orientation sensor's errors (an InertiaCube3, Sugiyama & Miura Table I), seeded.

The continuous-time model (IEEE Std 952 / Kalibr convention) for one axis is
``y(t) = x(t) + b(t) + n(t)`` with white noise ``n`` of density ``sigma_n`` (unit/sqrt(Hz)) and
``db/dt = w`` with ``w`` white of density ``sigma_b`` (unit/s/sqrt(Hz)). Sampled every ``dt``:
``n_k ~ N(0, sigma_n^2 / dt)`` and ``b_k = b_{k-1} + N(0, sigma_b^2 dt)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation


def sample_dt(times: np.ndarray, start: int = 0, stop: int | None = None) -> np.ndarray:
    """``(m, 1)`` intervals ``t_k - t_{k-1}`` (at least 1 ns) of samples ``[start, stop)``;
    the first sample's is its successor's (1 s if alone)."""
    n = len(times)
    prev = (times[0] - (times[1] - times[0] if n > 1 else 1.0)) if start == 0 \
        else times[start - 1]
    dt = np.diff(times[start:stop], prepend=prev)
    return np.maximum(dt, 1e-9)[:, None]


def walk_and_white(true: np.ndarray | None, dt: np.ndarray, noise_density: float,
                   bias_walk: float, white_normals: np.ndarray | None,
                   step_normals: np.ndarray, first: bool, bias_before: np.ndarray,
                   bias0: np.ndarray | None = None) -> tuple[np.ndarray | None, np.ndarray]:
    """Measurements and biases ``(m, 3)`` of consecutive samples from standard normals: the
    walk's steps ``N(0, sigma_b^2 dt)`` summed on from ``bias_before`` (none before the run's
    ``first`` sample), white noise ``N(0, sigma_n^2 / dt)``. ``true`` None: the biases only."""
    steps = step_normals * (bias_walk * np.sqrt(dt))
    if first:
        steps[0] = 0.0
    bias = (np.cumsum(np.concatenate([np.asarray(bias_before, float)[None], steps]),
                      axis=0)[1:] + (0.0 if bias0 is None else bias0))
    if true is None:
        return None, bias
    return true + bias + white_normals * (noise_density / np.sqrt(dt)), bias


def add_white_and_walk(true: np.ndarray, times: np.ndarray, noise_density: float,
                       bias_walk: float, rng: np.random.Generator,
                       bias0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Measurements ``(N, 3)`` and biases ``(N, 3)`` for true values ``(N, 3)`` at ``times``."""
    true = np.asarray(true, dtype=float)
    if len(times) == 0:
        return true.copy(), np.zeros_like(true)
    white = rng.standard_normal(true.shape)
    steps = rng.standard_normal(true.shape)
    return walk_and_white(true, sample_dt(times), noise_density, bias_walk, white, steps, True,
                          np.zeros(true.shape[1:]), bias0)


@dataclass(frozen=True)
class InertialSamples:
    """A whole run of one inertial sensor: sample times (s) and readings in the sensor frame."""

    t: np.ndarray
    accel: np.ndarray
    """Specific force (m/s^2), gravity included, as an accelerometer reads it."""
    gyro: np.ndarray
    """Angular velocity (rad/s)."""
    accel_true: np.ndarray
    gyro_true: np.ndarray
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
    orientation: OrientationSamples | None = None
    """The orientation output (an InertiaCube3), when the sensor has one."""


def simulate_inertial(t: np.ndarray, accel_true: np.ndarray, gyro_true: np.ndarray, cfg,
                      rng: np.random.Generator) -> InertialSamples:
    """Noisy readings of a sensor configured by ``cfg`` (a ``sensors.config.Inertial``)."""
    accel, b_a = add_white_and_walk(accel_true, t, cfg.accel_noise_density,
                                    cfg.accel_bias_walk, rng)
    gyro, b_g = add_white_and_walk(gyro_true, t, cfg.gyro_noise_density, cfg.gyro_bias_walk, rng)
    return InertialSamples(t, accel, gyro, accel_true, gyro_true, b_a, b_g)


# ---- orientation (an InertiaCube3-like sensor) -------------------------------------------------
#: Euler sequence of the orientation errors: intrinsic yaw about the reference frame's up axis
#: (y, as in the paper's W), then pitch about the sensor's x (left), then roll about its z.
EULER = "YXZ"


def gauss_markov(n: int, dt: float, sigma: np.ndarray, tau: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
    """``(n, D)`` first-order Gauss-Markov processes, stationary from the first sample:
    ``e_k = phi e_{k-1} + sqrt(1 - phi^2) sigma w_k``, ``phi = exp(-dt / tau)``, so every
    sample has standard deviation ``sigma`` and the correlation time is ``tau`` (s)."""
    sigma = np.asarray(sigma, float)
    phi = np.exp(-dt / np.asarray(tau, float))
    w = rng.standard_normal((n, len(sigma))) * sigma * np.sqrt(1.0 - phi**2)
    if n:
        w[0] = rng.standard_normal(len(sigma)) * sigma  # e_0 from the stationary law
    return np.stack([lfilter([1.0], [1.0, -phi[i]], w[:, i]) for i in range(len(sigma))],
                    axis=1).reshape(n, len(sigma))


def orientation_noise(cfg) -> tuple[np.ndarray, np.ndarray, float]:
    """``(slow, tau, res)`` of an orientation sensor configured by ``cfg`` (a
    ``sensors.config.HeadInertial``): RMS (rad) and correlation times (s) of the slowly
    varying yaw, pitch, roll errors, and the white noise (rad) of ``resolution_deg``."""
    rms = np.radians([cfg.yaw_rms_deg, cfg.tilt_rms_deg, cfg.tilt_rms_deg])
    res = np.radians(cfg.resolution_deg)
    # the slow part carries rms^2 - res^2 so the total RMS per axis is the configured one
    slow = np.sqrt(np.maximum(rms**2 - res**2, 0.0))
    tau = np.array([cfg.yaw_tau_s, cfg.tilt_tau_s, cfg.tilt_tau_s])
    return slow, tau, res


def orientation_errors(n: int, dt: float, cfg, rng: np.random.Generator) -> np.ndarray:
    """``(n, 3)`` yaw, pitch, roll errors (rad) of an orientation sensor configured by ``cfg``
    (a ``sensors.config.HeadInertial``): slowly varying errors of RMS ``yaw_rms_deg`` and
    ``tilt_rms_deg`` (Sugiyama & Miura, Table I), correlation times ``yaw_tau_s`` (the slow
    yaw drift) and ``tilt_tau_s``, plus white noise of ``resolution_deg`` per axis."""
    slow, tau, res = orientation_noise(cfg)
    return gauss_markov(n, dt, slow, tau, rng) + rng.standard_normal((n, 3)) * res


def perturb_orientation(R_ref_sensor: np.ndarray, errors: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` orientations whose yaw/pitch/roll (:data:`EULER`) are those of
    ``R_ref_sensor`` plus ``errors`` ``(N, 3)`` (rad)."""
    ypr = Rotation.from_matrix(R_ref_sensor).as_euler(EULER)
    return Rotation.from_euler(EULER, ypr + errors).as_matrix()


@dataclass(frozen=True)
class OrientationSamples:
    """A whole run of an orientation sensor: measured and true ``R_ref_sensor`` (N, 3, 3) and
    the yaw/pitch/roll errors (rad, :data:`EULER`)."""

    t: np.ndarray
    R: np.ndarray
    R_true: np.ndarray
    errors: np.ndarray


def simulate_orientation(t: np.ndarray, R_ref_sensor: np.ndarray, cfg,
                         rng: np.random.Generator) -> OrientationSamples:
    """Measured orientations at ``t`` for true ones ``R_ref_sensor`` (N, 3, 3)."""
    dt = float(np.mean(np.diff(t))) if len(t) > 1 else 1.0 / cfg.rate
    err = orientation_errors(len(t), dt, cfg, rng)
    return OrientationSamples(t, perturb_orientation(R_ref_sensor, err), R_ref_sensor, err)
