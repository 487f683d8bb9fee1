"""The Wii-remote arm EKF of Sugiyama & Miura (Sec. IV): the remote's pose in the head frame.

State ``x_A^I = (p, q, v, w, a, b)`` (eq. 10) with the random-jerk quaternion motion model
(eqs. 3-4, :mod:`~humimic.estimation.ekf.jerk_model`); measurements (eq. 11, models in
:mod:`~humimic.estimation.ekf.arm_model`): the marker's centroid (sigma 10/3 px) and area
(sigma 0.3 Z) per head-camera frame, the gyro with the head's rotation removed (sigma
0.01 rad/s) and the accelerometer's pitch and roll while the remote is still (sigma 0.5 deg).
The accelerometer bias ``b`` is in the state because the paper keeps the model's shape; no arm
measurement sees it (eq. 11 has no acceleration model), so it only carries its prior.

:class:`ArmEKF` is the thin stateful wrapper: it predicts to each measurement's time and
applies the measurement; the caller feeds measurements in time order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from humimic.estimation.ekf import arm_model as am
from humimic.estimation.ekf.jerk_model import (
    DIM,
    A,
    B,
    JerkNoise,
    P,
    Q,
    V,
    W,
    normalize_quaternion,
    predict,
    rotation,
)
from humimic.maths.kalman import kalman_update, nis
from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True)
class ArmNoise:
    """Measurement standard deviations (Sugiyama Sec. IV-B) and the initial uncertainty."""

    centroid_px: float = 10.0 / 3.0
    area_rel: float = 0.3
    """sigma of the area as a fraction of the measured area (the paper's 0.3 Z)."""
    gyro: float = 0.01
    """rad/s."""
    pitch_roll: float = math.radians(0.5)
    """rad."""
    init_quat: float = 0.05
    """Per quaternion component (about 6 deg)."""
    init_vel: float = 0.5
    init_rate: float = 1.0
    init_acc: float = 2.0
    init_bias: float = 0.1


def marker_depth(area_px: float, K: Intrinsics, marker_area_m2: float) -> float:
    """Depth (m) at which a marker of ``marker_area_m2`` facing the camera covers ``area_px``."""
    return math.sqrt(K.fx * K.fy * marker_area_m2 / area_px)


def initial_state(uv: np.ndarray, area_px: float, q0: np.ndarray, K: Intrinsics,
                  marker_area_m2: float, noise: ArmNoise) -> tuple[np.ndarray, np.ndarray]:
    """State and covariance from one marker measurement (depth from its area, the remote
    facing the camera) and a start orientation ``q0``; at rest, with the priors' spread."""
    z = marker_depth(area_px, K, marker_area_m2)
    x = np.zeros(DIM)
    x[P] = z * np.array([(uv[0] - K.cx) / K.fx, (uv[1] - K.cy) / K.fy, 1.0])
    x[Q] = q0
    s_xy = noise.centroid_px * z / K.fx
    s_z = 0.5 * noise.area_rel * z  # Z ~ area^-1/2
    var = np.concatenate([[s_xy**2, s_xy**2, s_z**2], np.full(4, noise.init_quat**2),
                          np.full(3, noise.init_vel**2), np.full(3, noise.init_rate**2),
                          np.full(3, noise.init_acc**2), np.full(3, noise.init_bias**2)])
    return x, np.diag(var)


class ArmEKF:
    """Predict/update of the arm state; ``x``, ``P`` and ``t`` are the latest estimate."""

    def __init__(self, K: Intrinsics, corners_A: np.ndarray, motion: JerkNoise | None = None,
                 noise: ArmNoise | None = None, use_area: bool = True,
                 gate_prob: float | None = 0.9999, pitch_roll: str = "gravity",
                 max_gap: float = 0.25, max_rejected: int = 3, min_depth: float = 0.05):
        self.K = K
        self.corners_A = np.asarray(corners_A, float)
        self.marker_area_m2 = am.quad_area(self.corners_A[:, :2])[0]
        self.motion = motion or JerkNoise()
        self.noise = noise or ArmNoise()
        self.use_area = use_area
        self.gate = {d: chi2.ppf(gate_prob, d) for d in (1, 2, 3)} if gate_prob else None
        self.x: np.ndarray | None = None
        self.P: np.ndarray | None = None
        self.t = -math.inf
        self.rejected = 0
        """Marker measurements gated out in all."""
        self.run_rejected = 0
        """Consecutive marker measurements gated out."""
        self.restarts = 0
        self.t_marker = -math.inf
        """Time of the last accepted marker measurement."""
        self.pitch_roll_mode = pitch_roll
        self.f_A: np.ndarray | None = None
        """The latest accelerometer reading (A frame), for the start orientation."""
        self.t_gyro: float | None = None
        self.max_gap = max_gap
        """Seconds without an accepted marker after which the next one restarts the position
        (a long prediction of the random-jerk model is no better than a fresh start, and a
        gated-out marker that stays where it is gets taken)."""
        self.max_rejected = max_rejected
        """Consecutive gated-out markers after which the next one restarts the position."""
        self.min_depth = min_depth
        """An update that would put the marker nearer than this (m) is refused: a point and
        its mirror behind the camera project alike, with the same area."""

    @property
    def initialized(self) -> bool:
        return self.x is not None

    def initialize(self, t: float, uv: np.ndarray, area_px: float, q0: np.ndarray) -> None:
        self.x, self.P = initial_state(uv, area_px, q0, self.K, self.marker_area_m2,
                                       self.noise)
        self.t = self.t_marker = t
        self.run_rejected = 0

    def predict(self, t: float) -> None:
        """Move the estimate to time ``t`` (s); earlier times are ignored."""
        if t > self.t:
            self.x, self.P = predict(self.x, self.P, t - self.t, self.motion)
            self.t = t

    def _update(self, y: np.ndarray, H: np.ndarray, R: np.ndarray, gated: bool) -> float:
        """One Kalman update with innovation ``y``; returns its NIS (NaN if gated out)."""
        S = H @ self.P @ H.T + R
        d2 = nis(y, S)
        if gated and self.gate is not None and d2 > self.gate[len(y)]:
            self.rejected += 1
            self.run_rejected += 1
            return math.nan
        x, Pn, _ = kalman_update(self.x, self.P, y, H, R)
        if x[2] < self.min_depth:
            self.rejected += 1
            self.run_rejected += 1
            return math.nan
        self.x, self.P = normalize_quaternion(x, Pn)
        return d2

    def update_marker(self, t: float, uv: np.ndarray, area_px: float) -> float:
        """Marker centroid (undistorted px) and area (px^2).  # Sugiyama eqs. 12-14"""
        self.predict(t)
        h, H = am.centroid(self.x, self.K)
        y, R = uv - h, np.eye(2) * self.noise.centroid_px**2
        if self.use_area:
            ha, Ha = am.marker_area(self.x, self.K, self.corners_A)
            y = np.append(y, area_px - ha)
            H = np.vstack([H, Ha])
            R = np.diag([R[0, 0], R[1, 1], (self.noise.area_rel * area_px) ** 2])
        d2 = self._update(y, H, R, gated=True)
        if math.isfinite(d2):
            self.t_marker = t
            self.run_rejected = 0
        return d2

    def update_gyro(self, t: float, w_rel_A: np.ndarray) -> float:
        """The remote's rate relative to the head, in A (:func:`arm_model.relative_rate`).
        # Sugiyama eq. 15"""
        self.predict(t)
        h, H = am.gyro(self.x)
        return self._update(w_rel_A - h, H, np.eye(3) * self.noise.gyro**2, gated=False)

    def update_pitch_roll(self, t: float, z: np.ndarray, d_I: np.ndarray) -> float:
        """Pitch and roll (rad) against the down direction ``d_I``.  # Sugiyama eqs. 19-24"""
        self.predict(t)
        h, H = am.pitch_roll(self.x, d_I)
        return self._update(z - h, H, np.eye(2) * self.noise.pitch_roll**2, gated=False)

    # ---- one sensor sample at a time (what the stage calls) ------------------------------
    def on_wii(self, t: float, gyro_A: np.ndarray, f_A: np.ndarray, w_head_I: np.ndarray,
               R_WI: np.ndarray) -> None:
        """A Wii-remote sample (gyro rad/s, specific force m/s^2, both in A) with the head's
        body rate ``w_head_I`` and orientation ``R_WI`` at ``t``."""
        dt = None if self.t_gyro is None else t - self.t_gyro
        self.t_gyro, self.f_A = t, np.asarray(f_A, float)
        if not self.initialized or not dt or dt <= 0.0:
            return
        self.update_gyro(t, am.relative_rate(gyro_A, self.q, w_head_I, dt))
        if am.accel_is_static(f_A, rotation(self.q), R_WI):
            z, d_I = am.pitch_roll_measurement(f_A, R_WI, self.pitch_roll_mode)
            self.update_pitch_roll(t, z, d_I)

    def on_marker(self, t: float, uv: np.ndarray, area_px: float, R_WI: np.ndarray) -> float:
        """A marker measurement; the first one starts the filter (the remote pointing ahead,
        pitch and roll from the latest accelerometer sample); one after ``max_gap`` or
        ``max_rejected`` gated-out ones restarts the position, the orientation kept. Returns
        the update's NIS (NaN: gated out or started)."""
        if (not self.initialized or t - self.t_marker > self.max_gap
                or self.run_rejected >= self.max_rejected):
            if self.initialized:
                q0 = self.q.copy()
                self.restarts += 1
            elif self.f_A is not None:
                q0 = am.start_pose(self.f_A, R_WI)
            else:
                q0 = np.array([1.0, 0.0, 0.0, 0.0])
            self.initialize(t, uv, area_px, q0)
            return math.nan
        return self.update_marker(t, uv, area_px)

    # ---- views ----------------------------------------------------------------------------
    @property
    def p(self) -> np.ndarray:
        return self.x[P]

    @property
    def q(self) -> np.ndarray:
        return self.x[Q]

    @property
    def v(self) -> np.ndarray:
        return self.x[V]

    @property
    def w(self) -> np.ndarray:
        return self.x[W]

    @property
    def a(self) -> np.ndarray:
        return self.x[A]

    @property
    def b(self) -> np.ndarray:
        return self.x[B]
