"""The arm EKF's noise from the configured sensors (:mod:`humimic.estimation.ekf.arm_noise`)
against independent computations, and the orientation error's tilt/yaw split against scipy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.estimation.ekf.arm_config import ArmConfig
from humimic.estimation.ekf.arm_noise import gyro_std, pitch_roll_std
from humimic.estimation.ekf.arm_record import tilt_and_yaw
from humimic.motion import quat
from humimic.sensors.config import Sensors

G = 9.81


def test_gyro_std_is_the_white_noise_of_both_gyros():
    s = Sensors()
    wii, imu = s.wiimote, s.imu
    # the white noise of a density sampled at a rate, per sample: density * sqrt(rate)
    assert gyro_std(wii) == pytest.approx(5.0e-4 * math.sqrt(100.0))
    assert gyro_std(wii, imu) == pytest.approx(math.hypot(5.0e-4 * 10.0,
                                                          1.7e-4 * math.sqrt(180.0)))


def test_pitch_roll_std_of_the_static_gate_matches_monte_carlo():
    """A dynamic acceleration uniform in the gate's ball (radius tol g) tilts the measured
    down by atan(a_h / g) about each horizontal axis: its RMS is the derived tol / sqrt(5)."""
    s = Sensors()
    wii = s.wiimote.model_copy(update={"accel_noise_density": 0.0})
    tol = 0.02
    rng = np.random.default_rng(0)
    a = rng.normal(size=(200_000, 3))
    a *= (tol * G * rng.random(len(a)) ** (1 / 3) / np.linalg.norm(a, axis=1))[:, None]
    f = a + np.array([0.0, G, 0.0])  # specific force at rest points up (y)
    pitch = np.arctan2(f[:, 2], f[:, 1])  # tilt about x
    assert pitch_roll_std(wii, tol, G) == pytest.approx(np.sqrt(np.mean(pitch**2)), rel=0.02)
    # the three terms add in variance
    full = pitch_roll_std(s.wiimote, tol, G, math.radians(0.25))
    white = 2.7e-3 * 10.0 / G
    assert full == pytest.approx(math.sqrt(white**2 + tol**2 / 5 + math.radians(0.25) ** 2))


def test_noise_source_and_overrides():
    s = Sensors()
    paper = ArmConfig.model_validate({"noise": {"source": "paper"}}).arm_noise(s)
    assert (paper.centroid_px, paper.area_rel, paper.gyro) == (10 / 3, 0.3, 0.01)
    assert paper.pitch_roll == pytest.approx(math.radians(0.5))
    ours = ArmConfig().arm_noise(s)
    assert (ours.centroid_px, ours.area_rel) == (0.35, 0.035)
    assert ours.gyro == pytest.approx(gyro_std(s.wiimote, s.imu))
    oracle = ArmConfig(head_pose="oracle").arm_noise(s)
    assert oracle.gyro == pytest.approx(gyro_std(s.wiimote))
    assert oracle.pitch_roll < ours.pitch_roll  # no head tilt error
    set_ = ArmConfig.model_validate({"noise": {"area_rel": 0.1, "pitch_roll_deg": 1.0}})
    n = set_.arm_noise(s)
    assert n.area_rel == 0.1 and n.pitch_roll == pytest.approx(math.radians(1.0))
    assert n.centroid_px == 0.35


def test_tilt_and_yaw_split_a_composed_rotation():
    """R_err = R_swing R_twist, the twist about the down direction by yaw and the swing about
    an axis orthogonal to it by tilt (scipy), recovered by the split."""
    rng = np.random.default_rng(1)
    n = 50
    down = Rotation.random(n, random_state=2).apply([0.0, -1.0, 0.0])
    perp = np.cross(down, rng.normal(size=(n, 3)))
    perp /= np.linalg.norm(perp, axis=1)[:, None]
    yaw = rng.uniform(-170, 170, n)
    tilt = rng.uniform(0, 60, n)
    R_twist = Rotation.from_rotvec(np.radians(yaw)[:, None] * down).as_matrix()
    R_swing = Rotation.from_rotvec(np.radians(tilt)[:, None] * perp).as_matrix()
    R_true = Rotation.random(n, random_state=3).as_matrix()
    R_est = R_swing @ R_twist @ R_true
    t, y = tilt_and_yaw(R_est, R_true, down)
    np.testing.assert_allclose(t, tilt, atol=1e-6)
    np.testing.assert_allclose(y, yaw, atol=1e-6)
    np.testing.assert_allclose(quat.twist_angle(R_twist, down), np.radians(yaw), atol=1e-9)
