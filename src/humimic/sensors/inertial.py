"""Accelerometer and gyroscope noise: white noise plus a bias random walk, seeded.

The continuous-time model (IEEE Std 952 / Kalibr convention) for one axis is
``y(t) = x(t) + b(t) + n(t)`` with white noise ``n`` of density ``sigma_n`` (unit/sqrt(Hz)) and
``db/dt = w`` with ``w`` white of density ``sigma_b`` (unit/s/sqrt(Hz)). Sampled every ``dt``:
``n_k ~ N(0, sigma_n^2 / dt)`` and ``b_k = b_{k-1} + N(0, sigma_b^2 dt)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def add_white_and_walk(true: np.ndarray, times: np.ndarray, noise_density: float,
                       bias_walk: float, rng: np.random.Generator,
                       bias0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Measurements ``(N, 3)`` and biases ``(N, 3)`` for true values ``(N, 3)`` at ``times``."""
    true = np.asarray(true, dtype=float)
    n = len(times)
    if n == 0:
        return true.copy(), np.zeros_like(true)
    dt = np.diff(times, prepend=times[0] - (times[1] - times[0] if n > 1 else 1.0))
    dt = np.maximum(dt, 1e-9)[:, None]
    white = rng.standard_normal(true.shape) * (noise_density / np.sqrt(dt))
    steps = rng.standard_normal(true.shape) * (bias_walk * np.sqrt(dt))
    steps[0] = 0.0
    bias = np.cumsum(steps, axis=0) + (0.0 if bias0 is None else bias0)
    return true + bias + white, bias


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


def simulate_inertial(t: np.ndarray, accel_true: np.ndarray, gyro_true: np.ndarray, cfg,
                      rng: np.random.Generator) -> InertialSamples:
    """Noisy readings of a sensor configured by ``cfg`` (a ``sensors.config.Inertial``)."""
    accel, b_a = add_white_and_walk(accel_true, t, cfg.accel_noise_density,
                                    cfg.accel_bias_walk, rng)
    gyro, b_g = add_white_and_walk(gyro_true, t, cfg.gyro_noise_density, cfg.gyro_bias_walk, rng)
    return InertialSamples(t, accel, gyro, accel_true, gyro_true, b_a, b_g)
