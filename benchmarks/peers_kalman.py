"""Our random-jerk Kalman filter vs ``cv2.KalmanFilter`` and filterpy's ``KalmanFilter``,
configured identically (same A, Q, H, R, x0, P0; float64), on the same measurements.

The sequence: a 60 Hz 3-D hand trajectory (a wave) measured with noise whose covariance R
changes every frame (as stereo's propagated R does); every 20th frame is missed (prediction
only). Each peer is fed the same numbers; the states after every step must agree (asserted,
relative 1e-6 of the state's scale) before anything is timed. Time per step = predict + update.
filterpy and we update P in the Joseph form; OpenCV as (I - KH) P, which on this problem (P0 with
acceleration variance 1e4 against R ~ 1e-5) loses symmetry and diverges within ~100 steps, so
the OpenCV peer symmetrises P after each ``correct()`` (as we do) - then all three agree to
rounding. The plain OpenCV filter's divergence is recorded in the result's note.
"""

from __future__ import annotations

import cv2
import numpy as np
from _harness import Peer, per_call, row, skipped

DT = 1.0 / 60.0
N = 600
MISS_EVERY = 20


def measurements(seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    p = np.stack([1.2 + 0.02 * np.sin(2 * np.pi * 0.5 * t), -0.3 + 0.25 * np.sin(np.pi * t),
                  1.5 + 0.05 * np.cos(np.pi * t)], 1)
    R = np.empty((N, 3, 3))
    for i in range(N):
        a = rng.normal(size=(3, 3)) * 3e-3
        R[i] = a @ a.T + np.diag([4e-4, 1e-5, 1e-5])  # depth noisier, as stereo
    z = np.stack([rng.multivariate_normal(p[i], R[i]) for i in range(N)])
    return t, z, R


def run_ours(t, z, R) -> np.ndarray:
    from humimic.estimation.random_jerk import B_PAPER_SI, RandomJerkFilter

    kf = RandomJerkFilter(B_PAPER_SI)
    out = np.empty((N, 9))
    for i in range(N):
        miss = i % MISS_EVERY == MISS_EVERY - 1
        out[i] = kf.step(t[i], None if miss else z[i], None if miss else R[i])
    return out


def _model():
    from humimic.estimation.random_jerk import (
        B_PAPER_SI,
        H,
        initial_state,
        process_noise,
        transition,
    )

    return transition(DT), process_noise(DT, B_PAPER_SI), H, initial_state


def run_opencv(t, z, R, symmetrize: bool = True) -> np.ndarray:
    """``symmetrize``: P <- (P + P^T) / 2 after ``correct()``, as ours does (without it the
    (I - KH) P update drifts off symmetry and diverges on this problem: see the row's note)."""
    A, Q, H, initial_state = _model()
    kf = cv2.KalmanFilter(9, 3, 0, cv2.CV_64F)
    kf.transitionMatrix, kf.processNoiseCov, kf.measurementMatrix = A.copy(), Q.copy(), H.copy()
    x0, P0 = initial_state(z[0], R[0])
    kf.statePost, kf.errorCovPost = x0.reshape(9, 1).copy(), P0.copy()
    out = np.empty((N, 9))
    out[0] = x0
    for i in range(1, N):
        kf.predict()
        if i % MISS_EVERY == MISS_EVERY - 1:
            kf.statePost, kf.errorCovPost = kf.statePre.copy(), kf.errorCovPre.copy()
        else:
            kf.measurementNoiseCov = R[i]
            kf.correct(z[i].reshape(3, 1))
            if symmetrize:
                P = kf.errorCovPost
                kf.errorCovPost = 0.5 * (P + P.T)
        out[i] = kf.statePost[:, 0]
    return out


def run_filterpy(t, z, R) -> np.ndarray:
    from filterpy.kalman import KalmanFilter

    A, Q, H, initial_state = _model()
    kf = KalmanFilter(dim_x=9, dim_z=3)
    kf.F, kf.Q, kf.H = A.copy(), Q.copy(), H.copy()
    x0, P0 = initial_state(z[0], R[0])
    kf.x, kf.P = x0.copy(), P0.copy()
    out = np.empty((N, 9))
    out[0] = x0
    for i in range(1, N):
        kf.predict()
        if i % MISS_EVERY != MISS_EVERY - 1:
            kf.update(z[i], R=R[i])
        out[i] = kf.x
    return out


def check_agreement(ours: np.ndarray, peer: np.ndarray, name: str) -> float:
    """Largest difference relative to each state component's scale; asserts <= 1e-6."""
    scale = np.maximum(np.abs(ours).max(axis=0), 1e-9)
    rel = float((np.abs(ours - peer) / scale).max())
    assert rel <= 1e-6, f"{name} disagrees with ours: max relative difference {rel:.2e}"
    return rel


def bench_kalman_peers(repeats: int) -> list[Peer]:
    t, z, R = measurements()
    ours = run_ours(t, z, R)
    peers = {"cv2.KalmanFilter": run_opencv}
    try:
        import filterpy  # noqa: F401

        peers["filterpy KalmanFilter"] = run_filterpy
    except ImportError:
        peers["filterpy KalmanFilter"] = None
    ours_row = row("filter", "random-jerk KF step (ours)",
                   [v / N for v in per_call(lambda: run_ours(t, z, R), repeats, 1)], "us", 1e6)
    plain = run_opencv(t, z, R, symmetrize=False)
    plain_mm = 1e3 * float(np.abs(plain[:, :3] - ours[:, :3]).max())
    out = []
    for name, fn in peers.items():
        if fn is None:
            peer = skipped("filter", name, "us", "filterpy is not installed (pip install "
                                                  "filterpy; it is in the test extra)")
            out.append(Peer("filter", f"Kalman step: ours vs {name}", ours_row, peer))
            continue
        rel = check_agreement(ours, fn(t, z, R), name)
        values = [v / N for v in per_call(lambda fn=fn: fn(t, z, R), repeats, 1)]
        peer = row("filter", f"{name} step", values, "us", 1e6, max_rel_diff=rel)
        note = f"9-state, same A Q H R x0 P0; states agree to {rel:.0e} (relative)"
        if name.startswith("cv2"):
            note += (f"; P symmetrised after correct() - unsymmetrised, cv2 drifts up to "
                     f"{plain_mm:.3g} mm from the others in {N} steps")
            peer.extra["unsymmetrised_max_position_diff_mm"] = plain_mm
        out.append(Peer("filter", f"Kalman step: ours vs {name}", ours_row, peer, note=note))
    return out
