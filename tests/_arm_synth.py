"""Synthetic data for the arm EKF: a turning head and a Wii remote moving in front of it.

Everything is analytic (sinusoids); the sensors' true readings come from finite differences of
the true poses (independent of the filter's models) and the noise has the filter's sigmas.
Frames as :mod:`humimic.world.frames`: W the paper's world (y up), I the head camera (x left,
y up, z forward; ``R_WI = I`` for a level head facing the screen), A the remote (``R_IA = I``
pointing ahead, buttons up); the head stands at W's origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.estimation.ekf import arm_model as am
from humimic.world.frames import GRAVITY_W

#: The marker of the simulated remote: a sphere of 2 cm radius.
RADIUS = 0.02


@dataclass
class ArmMotion:
    """Sinusoidal head rotation and remote motion, starting still; ``still`` freezes the remote
    in I (the head still turns)."""

    arm_amp: float = 0.08
    arm_rot_amp: float = 0.3
    head_rot_amp: float = 0.2
    freq: float = 0.4
    still: bool = False
    p0: tuple = (-0.1, -0.15, 0.55)

    def envelope(self, t, head=False):
        """0 before ``t = 0.5`` s (everything still to start), 1 after 1.5 s, smooth."""
        s = np.clip(t - 0.5, 0.0, 1.0)
        return 0.0 if self.still and not head else s * s * s * (10 - 15 * s + 6 * s * s)

    def p_IA(self, t):
        """(N, 3) for times (N,) or a scalar."""
        t = np.atleast_1d(np.asarray(t, float))[:, None]
        ph = np.array([0.0, 1.3, 2.1])
        return np.array(self.p0) + self.arm_amp * self.envelope(t) * np.sin(
            2 * np.pi * self.freq * t + ph)

    def R_IA(self, t):
        t = np.atleast_1d(np.asarray(t, float))[:, None]
        # no yaw (about y) at the start: the paper's start pose, the remote pointing ahead
        rv = np.array([0.2, 0.0, 0.15]) + self.arm_rot_amp * self.envelope(t) * np.sin(
            2 * np.pi * self.freq * 0.7 * t + np.array([0.5, 0.0, 2.0]))
        return Rotation.from_rotvec(rv.reshape(-1, 3))

    def R_WI(self, t):
        t = np.atleast_1d(np.asarray(t, float))[:, None]
        rv = self.head_rot_amp * self.envelope(t, head=True) * np.sin(
            2 * np.pi * self.freq * 1.3 * t + np.array([0.0, 0.7, 1.4]))
        return Rotation.from_rotvec(rv.reshape(-1, 3))

    def R_WA(self, t):
        return self.R_WI(t) * self.R_IA(t)


def body_rate(R_of_t, t, h=1e-5):
    """Body-frame angular velocity by a central difference of ``R_of_t`` (a Rotation batch)."""
    t = np.atleast_1d(t)
    return (R_of_t(t - h).inv() * R_of_t(t + h)).as_rotvec() / (2 * h)


def specific_force_A(m: ArmMotion, t, h=1e-3):
    """What the remote's accelerometer reads (A frame): ``R_WA^T (a_W - g_W)``."""
    t = np.atleast_1d(t)

    def p_W(s):
        return m.R_WI(s).apply(m.p_IA(s).reshape(-1, 3))
    a_W = (p_W(t + h) - 2 * p_W(t) + p_W(t - h)) / (h * h)
    return m.R_WA(t).inv().apply(a_W - GRAVITY_W)


def state_of(m: ArmMotion, t) -> np.ndarray:
    """The true 19-number state's position and orientation at ``t`` (the rest zero)."""
    x = np.zeros(19)
    x[0:3] = m.p_IA(t)[0]
    x[3:7] = np.roll(m.R_IA(t).as_quat()[0], 1)
    return x


def measurements(m: ArmMotion, duration: float, K, rng, cam_rate=30.0, imu_rate=100.0,
                 area_rel=0.05, centroid_px=10 / 3, gyro_std=0.01):
    """Time-ordered events ``(t, kind, value)``: ``marker`` (uv, area) and ``wii`` (gyro_A,
    f_A, w_head_I, R_WI)."""
    events = []
    for t in np.arange(1, int(duration * cam_rate)) / cam_rate:
        x = state_of(m, t)
        uv, _ = am.centroid(x, K)
        area, _ = am.sphere_area(x, K, RADIUS)
        events.append((t, "marker", (uv + rng.normal(scale=centroid_px, size=2),
                                     area * (1 + area_rel * rng.normal()))))
    t_imu = np.arange(1, int(duration * imu_rate)) / imu_rate
    gyro = body_rate(m.R_WA, t_imu) + rng.normal(scale=gyro_std, size=(len(t_imu), 3))
    w_head = body_rate(m.R_WI, t_imu)
    f_A = specific_force_A(m, t_imu)
    R_WI = m.R_WI(t_imu).as_matrix()
    for i, t in enumerate(t_imu):
        events.append((t, "wii", (gyro[i], f_A[i], w_head[i], R_WI[i])))
    events.sort(key=lambda e: e[0])
    return events
