"""The Wii-remote arm EKF of Sugiyama & Miura (Sec. IV): the remote's pose in the head frame.

State ``x_A^I = (p, q, v, w, a, b)`` (eq. 10) with the random-jerk quaternion motion model
shared with the head SLAM (eqs. 3-4, :mod:`.motion_model`); measurements (eq. 11, models in
:mod:`.arm_model`): the marker's centroid (sigma 10/3 px) and area (sigma 0.3 Z) per head-camera
frame, the gyro with the head's rotation removed (sigma 0.01 rad/s) and the accelerometer's
pitch and roll while the remote is still (sigma 0.5 deg). The accelerometer bias ``b`` is in the
state because the paper keeps the model's shape; no arm measurement sees it (eq. 11 has no
acceleration model), so it only carries its prior.

:class:`ArmEKF` is the thin stateful wrapper: it predicts to each measurement's time and applies
it; the caller feeds measurements in time order (:meth:`ArmEKF.on_wii`, :meth:`ArmEKF.on_marker`).
Beyond the paper, for robustness: a chi-square gate on the marker, an update that would put the
marker behind the camera refused, and a restart of the position after a gap or a run of
gated-out markers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from humimic.estimation.ekf import arm_model as am
from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import quaternion as qj
from humimic.estimation.ekf.motion_model import P, Q, V, W
from humimic.estimation.ekf.update import dense_PHt, dense_S, gain_update
from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True)
class ArmNoise:
    """Measurement standard deviations (Sugiyama Sec. IV-B) and the initial uncertainty. The
    stage's default is from the configured sensors instead (:mod:`.arm_noise`)."""

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


@dataclass(frozen=True)
class Marker:
    """The remote's red marker: a sphere of ``radius`` (m) or a flat plate with ``corners``
    (4x3, in A, around its centre, in order)."""

    radius: float | None = None
    corners: np.ndarray | None = None

    def __post_init__(self):
        if (self.radius is None) == (self.corners is None):
            raise ValueError("a marker is a sphere (radius) or a plate (corners), not both")

    def area(self, x: np.ndarray, K: Intrinsics) -> tuple[float, np.ndarray]:
        """Its projected area (px^2) and the Jacobian on the state's columns 0-6 (p, q; 1x7).
        # Sugiyama eq. 13"""
        if self.radius is not None:
            area, H = am.sphere_area(x, K, self.radius)
            return area, np.hstack([H, np.zeros((1, 4))])
        return am.plate_area(x, K, self.corners)

    def depth(self, area_px: float, K: Intrinsics) -> float:
        """Depth (m) at which the marker, on the optical axis (a plate facing the camera),
        covers ``area_px``."""
        if self.radius is not None:
            return math.sqrt(math.pi * K.fx * K.fy * self.radius**2 / area_px + self.radius**2)
        return math.sqrt(K.fx * K.fy * am.quad_area(self.corners[:, :2])[0] / area_px)


def initial_state(uv: np.ndarray, area_px: float, q0: np.ndarray, K: Intrinsics,
                  marker: Marker, noise: ArmNoise) -> tuple[np.ndarray, np.ndarray]:
    """State and covariance from one marker measurement (undistorted centroid, area: the depth
    from the area) and a start orientation ``q0``, at rest with the priors' spread. The
    position's covariance is the centroid's and the depth's carried through the back-projection
    ``p = z R_CV_I ((u - cx) / fx, (v - cy) / fy, 1)``: the depth's error lies along the ray,
    which off the optical axis moves x and y too."""
    z = marker.depth(area_px, K)
    ray_cv = np.array([(uv[0] - K.cx) / K.fx, (uv[1] - K.cy) / K.fy, 1.0])
    x = mm.initial_state(p=z * (am.R_CV_I @ ray_cv), q=q0)
    J = am.R_CV_I @ np.column_stack([[z / K.fx, 0.0, 0.0], [0.0, z / K.fy, 0.0], ray_cv])
    s_z = 0.5 * noise.area_rel * z  # depth ~ area^-1/2
    cov = np.diag(np.concatenate([np.zeros(3), np.full(4, noise.init_quat**2),
                                  np.full(3, noise.init_vel**2), np.full(3, noise.init_rate**2),
                                  np.full(3, noise.init_acc**2), np.full(3, noise.init_bias**2)]))
    cov[P, P] = (J * [noise.centroid_px**2, noise.centroid_px**2, s_z**2]) @ J.T
    return x, cov


class ArmEKF:
    """Predict/update of the arm state; ``x``, ``P`` and ``t`` are the latest estimate."""

    def __init__(self, K: Intrinsics, marker: Marker, motion: mm.MotionNoise | None = None,
                 noise: ArmNoise | None = None, use_area: bool = True,
                 pitch_roll: str = "gravity", gate_prob: float | None = 0.9999,
                 max_gap: float = 0.25, max_rejected: int = 3, min_depth: float = 0.05,
                 static_tol_g: float = 0.02):
        self.K, self.marker = K, marker
        self.motion = motion or mm.MotionNoise()
        self.noise = noise or ArmNoise()
        self.use_area = use_area
        self.pitch_roll_mode = pitch_roll
        self.static_tol_g = static_tol_g
        self.gate = {d: chi2.ppf(gate_prob, d) for d in (1, 2, 3)} if gate_prob else None
        self.max_gap = max_gap
        """Seconds without an accepted marker after which the next one restarts the position
        (a long prediction of the random-jerk model is no better than a fresh start)."""
        self.max_rejected = max_rejected
        """Gated-out markers in a row after which the next one restarts the position."""
        self.min_depth = min_depth
        """An update that would put the marker nearer than this (m) is refused: a point and
        its mirror behind the camera project alike, with the same area."""
        self.x: np.ndarray | None = None
        self.P: np.ndarray | None = None
        self.t = -math.inf
        self.t_marker = -math.inf
        """Time of the last accepted marker measurement."""
        self.t_gyro: float | None = None
        self.f_A: np.ndarray | None = None
        """The latest accelerometer reading (A frame), for the start orientation."""
        self.rejected = self.run_rejected = self.restarts = 0
        self.static_updates = 0

    @property
    def initialized(self) -> bool:
        return self.x is not None

    def initialize(self, t: float, uv: np.ndarray, area_px: float, q0: np.ndarray) -> None:
        self.x, self.P = initial_state(uv, area_px, q0, self.K, self.marker, self.noise)
        self.t = self.t_marker = t
        self.run_rejected = 0

    def predict(self, t: float) -> None:
        """Move the estimate to time ``t`` (s); earlier times are ignored."""
        if t > self.t:
            x, F, G = mm.predict(self.x, t - self.t)
            self.P = F @ self.P @ F.T + mm.process_noise(G, self.motion)
            self.x, self.t = x, t

    def _update(self, y: np.ndarray, cols: np.ndarray, H: np.ndarray, R: np.ndarray,
                gated: bool) -> float:
        """One Kalman update with innovation ``y`` and the Jacobian ``H`` on the state's
        columns ``cols``; returns its NIS when ``gated`` (else 0), NaN if refused."""
        PHt = dense_PHt(self.P, cols, H)
        S = dense_S(PHt, cols, H, R)
        d2 = 0.0
        if gated and self.gate is not None:
            d2 = float(y @ np.linalg.solve(S, y))
            if d2 > self.gate[len(y)]:
                self.rejected += 1
                self.run_rejected += 1
                return math.nan
        x, Pn = self.x.copy(), self.P.copy()
        gain_update(x, Pn, PHt, S, y)
        if x[2] < self.min_depth:
            self.rejected += 1
            self.run_rejected += 1
            return math.nan
        J = qj.d_normalize(x[Q])
        x[Q] /= np.linalg.norm(x[Q])
        Pn[Q, :] = J @ Pn[Q, :]
        Pn[:, Q] = Pn[:, Q] @ J.T
        self.x, self.P = x, 0.5 * (Pn + Pn.T)
        return d2

    def _marker_model(self) -> tuple[np.ndarray, np.ndarray]:
        """Predicted ``(u, v[, area])`` and its Jacobian on :data:`.arm_model.COLS_PQ`."""
        h, Hc = am.centroid(self.x, self.K)
        H = np.hstack([Hc, np.zeros((2, 4))])
        if self.use_area:
            ha, Ha = self.marker.area(self.x, self.K)
            h, H = np.append(h, ha), np.vstack([H, Ha])
        return h, H

    def _marker_R(self, area_px: float) -> np.ndarray:
        var = [self.noise.centroid_px**2] * 2
        if self.use_area:
            var.append((self.noise.area_rel * area_px) ** 2)
        return np.diag(var)

    def _marker_z(self, uv: np.ndarray, area_px: float) -> np.ndarray:
        return np.append(uv, area_px) if self.use_area else np.asarray(uv, float)

    def update_marker(self, t: float, uv: np.ndarray, area_px: float) -> float:
        """Marker centroid (undistorted px) and area (px^2).  # Sugiyama eqs. 12-14"""
        self.predict(t)
        h, H = self._marker_model()
        d2 = self._update(self._marker_z(uv, area_px) - h, am.COLS_PQ, H,
                          self._marker_R(area_px), gated=True)
        if math.isfinite(d2):
            self.t_marker = t
            self.run_rejected = 0
        return d2

    def marker_nis(self, t: float, candidates) -> np.ndarray:
        """NIS of each candidate ``(uv, area)`` against the prediction at ``t`` (the estimate
        is moved to ``t``)."""
        self.predict(t)
        h, H = self._marker_model()
        HPH = H @ self.P[:7, :7] @ H.T
        out = np.empty(len(candidates))
        for i, (uv, area) in enumerate(candidates):
            y = self._marker_z(uv, area) - h
            out[i] = float(y @ np.linalg.solve(HPH + self._marker_R(area), y))
        return out

    def update_gyro(self, t: float, w_rel_A: np.ndarray) -> float:
        """The remote's rate relative to the head, in A (:func:`.arm_model.relative_rate`).
        # Sugiyama eq. 15"""
        self.predict(t)
        h, H = am.gyro(self.x)
        return self._update(w_rel_A - h, am.COLS_W, H, np.eye(3) * self.noise.gyro**2,
                            gated=False)

    def update_pitch_roll(self, t: float, z: np.ndarray, d_I: np.ndarray) -> float:
        """Pitch and roll (rad) against the down direction ``d_I``.  # Sugiyama eqs. 19-24"""
        self.predict(t)
        h, H = am.pitch_roll(self.x, d_I)
        return self._update(z - h, am.COLS_Q, H, np.eye(2) * self.noise.pitch_roll**2,
                            gated=False)

    # ---- one sensor sample at a time (what the stage calls) ------------------------------
    def on_wii(self, t: float, gyro_A: np.ndarray, f_A: np.ndarray, w_head_I: np.ndarray,
               R_WI: np.ndarray) -> None:
        """A Wii-remote sample (gyro rad/s, specific force m/s^2, both in A) with the head's
        body rate ``w_head_I`` over the last step and its orientation ``R_WI`` at ``t``."""
        dt = None if self.t_gyro is None else t - self.t_gyro
        self.t_gyro, self.f_A = t, np.asarray(f_A, float)
        if not self.initialized or not dt or dt <= 0.0:
            return
        self.update_gyro(t, am.relative_rate(gyro_A, self.x[Q], w_head_I, dt))
        if am.accel_is_static(f_A, am.rotation(self.x[Q]), R_WI, self.static_tol_g):
            z, d_I = am.pitch_roll_measurement(f_A, R_WI, self.pitch_roll_mode)
            self.update_pitch_roll(t, z, d_I)
            self.static_updates += 1

    def needs_start(self, t: float) -> bool:
        """Whether a marker at ``t`` (re)starts the filter rather than updating it."""
        return (not self.initialized or t - self.t_marker > self.max_gap
                or self.run_rejected >= self.max_rejected)

    def on_marker(self, t: float, uv: np.ndarray, area_px: float, R_WI: np.ndarray) -> float:
        """A marker measurement; the first one after an accelerometer sample starts the filter
        (the remote pointing ahead, pitch and roll from that sample); one after ``max_gap`` or
        ``max_rejected`` gated-out ones restarts the position, the orientation kept. Returns
        the update's NIS (NaN: gated out or started)."""
        if self.needs_start(t):
            if self.initialized:
                q0 = self.x[Q].copy()
                self.restarts += 1
            elif self.f_A is not None:
                q0 = am.start_pose(self.f_A, R_WI)
            else:  # no accelerometer sample yet: wait for one
                return math.nan
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

