"""The paper's claim that a Kalman filter cannot track through joint end stops (Menezes sec.
6.3, after Deutscher et al.), measured beside TBP: Ude's random-jerk filter
(:class:`humimic.estimation.random_jerk.RandomJerkFilter`) on three right-arm angles, fed the
TRUE angles plus Gaussian noise (an oracle measurement, far easier than the images), keeps a
Gaussian belief that knows nothing of the limits: where the arm stops hard at an end stop its
constant-acceleration prediction overshoots beyond the limit. The particle filter clamps its
samples to the limits and cannot leave them.
"""

from __future__ import annotations

import numpy as np

from humimic.estimation.random_jerk import RandomJerkFilter

KALMAN_DOFS = ("R_SFE", "R_SAA", "R_EB")


def beyond_limits(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``(T, D)`` how far (rad) each angle lies outside ``[lower, upper]`` (0 inside)."""
    return np.maximum(lower - q, 0.0) + np.maximum(q - upper, 0.0)


def kalman_end_stops(times: np.ndarray, truth: np.ndarray, lower: np.ndarray,
                     upper: np.ndarray, sigma: float, b: float,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Filtered angles ``(T, 3)`` of noisy ``truth (T, 3)`` (rad) and the measurements."""
    kf = RandomJerkFilter(b=b)
    R = sigma ** 2 * np.eye(3)
    z = truth + rng.normal(0.0, sigma, truth.shape)
    est = np.array([kf.step(t, zk, R)[:3] for t, zk in zip(times, z, strict=True)])
    return est, z


def kalman_scores(est: np.ndarray, pf: np.ndarray, truth: np.ndarray, lower: np.ndarray,
                  upper: np.ndarray) -> dict:
    """Angle errors and excursions beyond the limits of the Kalman filter and of TBP."""
    out = {"dofs": list(KALMAN_DOFS)}
    for key, q in (("kalman", est), ("particle", pf), ("truth", truth)):
        beyond = np.degrees(beyond_limits(q, lower, upper))
        out[f"{key}_beyond_limits_fraction"] = float(np.mean(beyond.max(axis=1) > 0.1))
        out[f"{key}_max_beyond_limit_deg"] = float(beyond.max())
        if key != "truth":
            out[f"{key}_joint_rmse_deg"] = float(np.degrees(np.sqrt(np.mean((q - truth) ** 2))))
    return out
