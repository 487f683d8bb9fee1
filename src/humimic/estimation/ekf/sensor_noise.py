"""The SLAM filter's inertial measurement noise from the head IMU's own error model.

The filter fuses every IMU sample (180 Hz) as if its error were white. The orientation
sensor's error is not: an InertiaCube3's pitch/roll and yaw errors (Sugiyama & Miura Table I)
vary slowly -- :mod:`humimic.sensors.inertial` simulates them as first-order Gauss-Markov
processes (std ``σ``, correlation time ``τ``) plus a small white resolution noise. Fused as
white noise of the same RMS, N samples within one correlation time are believed to average
the error down by ``sqrt(N)``: the filter follows the sensor's slow tilt error and reports a
covariance far too small (position NEES 5-90 on the Fig. 8 jump, against 3).

White noise that carries the same information about a slow error has the same power at low
frequency. A Gauss-Markov error's (two-sided) spectral density at zero frequency is
``2 σ^2 τ``; white samples of variance ``σ_w^2`` at rate ``f`` have density ``σ_w^2 / f``, so
the white-equivalent per-sample std is ``σ_w = σ sqrt(2 τ f)`` (:func:`white_equivalent_std`;
e.g. Maybeck, *Stochastic Models, Estimation and Control* vol. 1, sec. 4.11, and the
Gauss-Markov/random-walk equivalence of Farrell, *Aided Navigation* sec. 4.9). Over windows
shorter than ``2 τ`` it claims less than the sensor gives (conservative), over longer ones
the same.

The measured orientation also rotates the accelerometer's specific force into W (eq. 7: ``a_W
= R_WI f_I + g``): a tilt error ``δ`` turns gravity into a horizontal acceleration ``g δ`` that
drifts with the tilt's correlation time. That, and the accelerometer's own bias random walk,
is what the filter's bias state ``b`` (in W) must follow: its drift comes from them
(:func:`accel_bias_drift_W`), and the acceleration's white noise is the accelerometer's
(``density sqrt(rate)``, :func:`accel_std_W`). The paper's 0.5 m/s^2 (against the simulated
sensor's 0.027) made the filter's acceleration lag the jump's take-off and landing (the
jerk's RMS is 121 m/s^3 there, the model's 15): the jump's height came out 2-4 % short.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.sensors.inertial import orientation_noise


def white_std(density: float, rate: float) -> float:
    """Per-sample std of white noise of ``density`` (unit/sqrt(Hz)) sampled at ``rate`` (Hz)."""
    return density * math.sqrt(rate)


def white_equivalent_std(sigma, tau, rate: float):
    """Per-sample std of white noise at ``rate`` (Hz) with the low-frequency power of a
    first-order Gauss-Markov error of std ``sigma`` and correlation time ``tau`` (s):
    ``sigma sqrt(2 tau rate)``."""
    return np.asarray(sigma, float) * np.sqrt(2.0 * np.asarray(tau, float) * rate)


def orientation_tilt_yaw(imu) -> tuple[float, float]:
    """``(tilt, yaw)`` (rad): the per-sample white-equivalent std of the orientation error of
    an IMU configured by ``imu`` (a ``sensors.config.HeadInertial``): each axis's slow part
    (Gauss-Markov) and its white resolution noise."""
    slow, tau, res = orientation_noise(imu)  # yaw, pitch, roll
    eq = np.sqrt(white_equivalent_std(slow, tau, imu.rate) ** 2 + res**2)
    return float(max(eq[1], eq[2])), float(eq[0])


def accel_std_W(imu, gravity: float) -> tuple[float, float, float]:
    """Per-sample std (m/s^2) of the white part of the acceleration in W that eq. 7 compares
    with, along W's x, y (up), z: the accelerometer's white noise (``density sqrt(rate)``) on
    every axis and, on the horizontal ones, gravity turned by the orientation's white
    resolution error. The slow tilt error's share is a drifting bias
    (:func:`accel_bias_drift_W`)."""
    white = white_std(imu.accel_noise_density, imu.rate)
    _, _, res = orientation_noise(imu)
    horizontal = math.hypot(white, abs(gravity) * res)
    return (horizontal, white, horizontal)


def accel_bias_drift_W(imu, gravity: float) -> tuple[float, float, float]:
    """Per-step std (m/s^3) of the bias drift ``b̄`` of eq. 5 along W's x, y (up), z, for steps
    of ``1 / imu.rate``: the filter's bias ``b`` (in W) gathers the accelerometer's bias random
    walk (density ``accel_bias_walk``) and, on the horizontal axes, gravity turned by the slow
    tilt error ``g δ``. A Gauss-Markov error drifts as a random walk of density
    ``σ sqrt(2 / τ)`` over lags short against ``τ`` (``Var(e(t+Δ) - e(t)) = 2 σ^2 (1 - e^{-Δ/τ})
    ≈ 2 σ^2 Δ / τ``). The paper's discrete drift adds ``(b̄ Δt)^2`` per step, a random walk of
    density ``q`` therefore ``b̄ = q sqrt(rate)``."""
    slow, tau, _ = orientation_noise(imu)  # yaw, pitch, roll
    walk = imu.accel_bias_walk
    tilt_walk = abs(gravity) * float(max(slow[1], slow[2])) * math.sqrt(2.0 / float(tau[1]))
    root = math.sqrt(imu.rate)
    horizontal = math.hypot(walk, tilt_walk) * root
    return (horizontal, walk * root, horizontal)
