"""A synthetic world for the EKF SLAM core: no images, exact models.

The truth is sampled from the filter's own motion model (Sugiyama eqs. 3-4 with the noises at
the IMU rate), the inertial measurements from eqs. 6-7 with their noises, and the image
measurements are the projections of 3-D points with 1 px noise, associated by an oracle (each
map feature knows which world point it came from). A consistent filter has NEES within its
chi-square band here; a wrong Jacobian or noise term shows up at once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import quaternion as quat_jac  # noqa: F401 (tests use it)
from humimic.estimation.ekf.slam import SlamFilter, SlamParams
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics

INTR = Intrinsics(368, 240, 320.0, 320.0, 183.5, 119.5)
#: The paper's interface frame I (x left, y up, z forward) to OpenCV's camera axes.
R_CV_I = np.diag([-1.0, -1.0, 1.0])
SCREEN = np.array([[0.61, 0.455, 2.0], [-0.61, 0.455, 2.0], [-0.61, -0.455, 2.0],
                   [0.61, -0.455, 2.0]])


def world_points(rng: np.random.Generator, n: int = 400) -> np.ndarray:
    """Points on a sphere shell of radius 3-6 m around (0, 0, -2.5): some are always in view."""
    d = quat.normalize(rng.standard_normal((n, 3)))
    return np.array([0.0, 0.0, -2.5]) + d * rng.uniform(3.0, 6.0, (n, 1))


def sample_truth(rng: np.random.Generator, x0: np.ndarray, duration: float, rate: float,
                 noise: mm.MotionNoise) -> tuple[np.ndarray, np.ndarray]:
    """Times ``(N,)`` and states ``(N, 19)`` following the model with sampled noise."""
    dt = 1.0 / rate
    n = int(round(duration * rate)) + 1
    X = np.empty((n, mm.DIM))
    X[0] = x0
    sd = np.repeat([noise.jerk, noise.alpha, noise.bias], 3)
    for k in range(1, n):
        x, _, G = mm.predict(X[k - 1], dt)
        X[k] = x + G @ (sd * rng.standard_normal(9))
        X[k, 3:7] = quat.normalize(X[k, 3:7])
    return np.arange(n) * dt, X


@dataclass
class SynthRun:
    t: np.ndarray
    truth: np.ndarray
    est: np.ndarray
    cov: np.ndarray
    """(N, 19, 19) interface covariance."""
    frames: list[int] = field(default_factory=list)
    """Indices into ``t`` where a frame was fused."""
    matched: list[int] = field(default_factory=list)
    filt: SlamFilter | None = None


def run(seed: int = 0, duration: float = 3.0, imu_rate: float = 180.0, cam_every: int = 6,
        n_target: int = 12, known: bool = True, use_imu: bool = True,
        use_camera: bool = True, params: SlamParams | None = None) -> SynthRun:
    """Run the filter over a sampled trajectory; returns truth and estimates at IMU times."""
    params = params or SlamParams()
    rng = np.random.default_rng(seed)
    pts = np.vstack([SCREEN, world_points(rng)])
    x0 = mm.initial_state(p=[0.0, 0.0, -2.5])
    t, X = sample_truth(rng, x0, duration, imu_rate, params.noise)
    P0 = np.diag(np.r_[np.full(3, 1e-6), np.full(4, 1e-8), np.full(12, 1e-6)])
    f = SlamFilter(0.0, x0, P0, INTR, R_CV_I, params)
    point_of: dict[int, int] = {}
    if known:
        for fid, i in zip(f.add_known(SCREEN), range(len(SCREEN)), strict=True):
            point_of[fid] = i
    sq, sa, spx = params.sigma_orientation, params.sigma_accel, params.sigma_px
    out = SynthRun(t, X, np.empty_like(X), np.empty((len(t), mm.DIM, mm.DIM)), filt=f)
    for k, tk in enumerate(t):
        f.predict(tk)
        x = X[k]
        if use_imu and k > 0:
            q_meas = quat.normalize(x[3:7] + sq * rng.standard_normal(4))
            a_meas = x[13:16] + x[16:19] + sa * rng.standard_normal(3)
            f.update_inertial(q_meas, a_meas)
        if use_camera and k % cam_every == 0:
            R = quat.to_matrix(x[3:7])
            uv_all = INTR.project((pts - x[0:3]) @ R @ R_CV_I.T)
            pred = f.predict_features()
            if len(pred.fids):
                idx = np.array([point_of[int(i)] for i in pred.fids])
                z = uv_all[idx] + spx * rng.standard_normal((len(idx), 2))
                ok = np.all(np.isfinite(z), axis=1)
                ok &= (z[:, 0] >= 0) & (z[:, 0] < INTR.width) & (z[:, 1] >= 0) & (
                    z[:, 1] < INTR.height)
                m = np.flatnonzero(ok)
                f.update_features(pred, m, z[m])
                out.matched.append(len(m))
                # features the oracle could not see count as failures and get pruned
                for fid in f.prune():
                    point_of.pop(fid, None)
            f.convert_linear()
            visible = len(pred.fids)
            if visible < n_target:
                used = set(point_of.values())
                inside = np.flatnonzero(
                    np.all(np.isfinite(uv_all), axis=1) & (uv_all[:, 0] > 10)
                    & (uv_all[:, 0] < INTR.width - 10) & (uv_all[:, 1] > 10)
                    & (uv_all[:, 1] < INTR.height - 10))
                new = [i for i in inside if i not in used][: n_target - visible]
                if new:
                    uv_new = uv_all[new] + spx * rng.standard_normal((len(new), 2))
                    for fid, i in zip(f.add_features(uv_new), new, strict=True):
                        point_of[fid] = i
            out.frames.append(k)
        out.est[k] = f.interface
        out.cov[k] = f.P_interface
    return out


def orientation_error(q_true: np.ndarray, q_est: np.ndarray) -> np.ndarray:
    """Small rotation vector ``δ`` with ``q_true = q_est ⊗ q(δ)`` (rad, in the body frame)."""
    return quat.to_rotvec(quat.mul(quat.conj(q_est), q_true))
