"""The arm EKF's measurement models (Sugiyama eqs. 12-24): analytic Jacobians vs finite
differences, values vs OpenCV, scipy and closed forms. (The shared motion model's own tests are
in ``test_ekf_jacobians.py``.)"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.estimation.ekf import arm_model as am
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics
from humimic.world.frames import GRAVITY_W, R_CV_I

K = Intrinsics.from_fovy(np.radians(45.0), 368, 240)
#: A 4 x 3 cm flat marker in A, corners in order around it.
CORNERS = np.array([[-0.02, -0.015, 0.0], [0.02, -0.015, 0.0], [0.02, 0.015, 0.0],
                    [-0.02, 0.015, 0.0]])
UP = -GRAVITY_W / np.linalg.norm(GRAVITY_W)


def random_state(rng) -> np.ndarray:
    x = np.zeros(19)
    x[0:3] = [rng.uniform(-0.2, 0.2), rng.uniform(-0.3, 0.1), rng.uniform(0.4, 0.8)]
    x[3:7] = quat.normalize(np.array([1.0, 0, 0, 0]) + 0.3 * rng.normal(size=4))
    x[7:] = rng.normal(size=12)
    return x


def numeric_jacobian(f, x, eps=1e-7):
    f0 = np.atleast_1d(f(x))
    J = np.empty((len(f0), len(x)))
    for i in range(len(x)):
        d = np.zeros(len(x))
        d[i] = eps
        J[:, i] = (np.atleast_1d(f(x + d)) - np.atleast_1d(f(x - d))) / (2 * eps)
    return J


def full(H, cols):
    """A model's Jacobian on its columns as the full (m, 19) one."""
    out = np.zeros((np.atleast_2d(H).shape[0], 19))
    out[:, cols] = H
    return out


def tangent(H, x):
    """``H`` on the unit quaternion's tangent space (the models normalise ``q``; the filter's
    covariance has no component along ``q``)."""
    H = np.array(H, float)
    q = x[3:7]
    H[:, 3:7] = H[:, 3:7] @ (np.eye(4) - np.outer(q, q))
    return H


def cv_project(p_I):
    uv, _ = cv2.projectPoints(np.atleast_2d(p_I) @ R_CV_I.T, np.zeros(3), np.zeros(3), K.K,
                              None)
    return uv.reshape(-1, 2)


def test_centroid_matches_opencv_and_jacobian():
    rng = np.random.default_rng(6)
    for _ in range(3):
        x = random_state(rng)
        uv, H = am.centroid(x, K)
        np.testing.assert_allclose(uv, cv_project(x[0:3])[0], atol=1e-9)
        np.testing.assert_allclose(full(H, am.COLS_P),
                                   numeric_jacobian(lambda y: am.centroid(y, K)[0], x), atol=1e-5)


def test_plate_area_matches_opencv_contour_area_and_jacobian():
    rng = np.random.default_rng(7)
    for _ in range(5):
        x = random_state(rng)
        area, H = am.plate_area(x, K, CORNERS)
        pts = x[0:3] + CORNERS @ quat.to_matrix(x[3:7]).T  # independent of am.rotation
        ref = cv2.contourArea(cv_project(pts).astype(np.float32))
        # measured <= 3.1e-7 relative and 3.8e-7 px^2 off (2026-11-29; the bounds were 1e-5
        # and rtol 1e-4 + atol 1e-3)
        assert area == pytest.approx(ref, rel=1e-6)
        Hn = numeric_jacobian(lambda y: am.plate_area(y, K, CORNERS)[0], x, eps=1e-6)
        np.testing.assert_allclose(tangent(full(H, am.COLS_PQ), x), tangent(Hn, x), rtol=0,
                                   atol=1e-6)


def test_plate_facing_the_camera_is_the_pinhole_closed_form():
    x = np.zeros(19)
    x[0:3], x[3] = [0.0, 0.0, 0.6], 1.0
    assert am.plate_area(x, K, CORNERS)[0] == pytest.approx(K.fx * K.fy * 0.04 * 0.03 / 0.36)


def test_sphere_area_matches_a_ray_cast_silhouette_and_jacobian():
    """The ellipse formula against counting the pixels whose ray hits the sphere (fine grid),
    on and off the optical axis."""
    r = 0.02
    for c_I in ([0.0, 0.0, 0.5], [-0.15, -0.08, 0.45], [0.18, 0.1, 0.35]):
        x = np.zeros(19)
        x[0:3], x[3] = c_I, 1.0
        area, H = am.sphere_area(x, K, r)
        c = R_CV_I @ np.array(c_I)
        uv0 = K.project(c)
        half = 2.0 * np.sqrt(area)
        step = 0.05  # px
        u, v = np.meshgrid(np.arange(uv0[0] - half, uv0[0] + half, step),
                           np.arange(uv0[1] - half, uv0[1] + half, step))
        rays = np.stack([(u - K.cx) / K.fx, (v - K.cy) / K.fy, np.ones_like(u)], -1)
        rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
        tc = rays @ c  # distance along the ray to the closest approach
        hit = (c @ c - tc * tc) <= r * r
        assert area == pytest.approx(hit.sum() * step * step, rel=1e-4)  # measured 3.3e-5
        Hn = numeric_jacobian(lambda y: am.sphere_area(y, K, r)[0], x)
        np.testing.assert_allclose(full(H, am.COLS_P), Hn, rtol=1e-5, atol=1e-6)


def test_relative_rate_matches_finite_difference_of_true_orientations():
    """Eqs. 16-18 against the rotation of R_IA = R_WI^T R_WA over one step (scipy)."""
    rng = np.random.default_rng(8)
    dt = 0.01
    R_WI0 = Rotation.random(random_state=9)
    R_IA0 = Rotation.from_rotvec(rng.normal(scale=0.5, size=3))
    w_I, w_A = rng.normal(scale=1.5, size=3), rng.normal(scale=2.0, size=3)
    R_WA0 = R_WI0 * R_IA0
    R_WI1 = R_WI0 * Rotation.from_rotvec(w_I * dt)  # body-frame rates
    R_WA1 = R_WA0 * Rotation.from_rotvec(w_A * dt)
    R_IA1 = R_WI1.inv() * R_WA1
    expected = (R_IA0.inv() * R_IA1).as_rotvec() / dt
    got = am.relative_rate(w_A, np.roll(R_IA0.as_quat(), 1), w_I, dt)
    np.testing.assert_allclose(got, expected, atol=1e-10)
    # and its small-step limit: w_A - R_AI w_I
    np.testing.assert_allclose(got, w_A - R_IA0.inv().apply(w_I), atol=0.05)


def test_pitch_roll_jacobian_and_exact_gravity_form():
    rng = np.random.default_rng(10)
    for _ in range(5):
        x = random_state(rng)
        d = quat.normalize(rng.normal(size=3))
        h, H = am.pitch_roll(x, d)
        Hn = numeric_jacobian(lambda y, d=d: am.pitch_roll(y, d)[0], x)
        # measured <= 8.9e-9 (2026-11-29; the bound was 1e-6)
        np.testing.assert_allclose(tangent(full(H, am.COLS_Q), x), tangent(Hn, x), atol=3e-8)
        # gravity mode is exact: the accelerometer's angles equal the model's with the true
        # orientations, for any head orientation
        R_WI = Rotation.random(random_state=int(rng.integers(1 << 30)))
        R_IA = Rotation.from_quat(np.roll(x[3:7], -1))
        f_A = (R_WI * R_IA).inv().apply(-GRAVITY_W)  # at rest: specific force up
        z, d_I = am.pitch_roll_measurement(f_A, R_WI.as_matrix(), "gravity")
        np.testing.assert_allclose(am.pitch_roll(x, d_I)[0], z, atol=1e-12)


def test_pitch_and_roll_signs_are_the_papers():
    """Eq. 19 with I's y up: pointing down is a positive pitch (``-arctan(y/..)``), the left
    side (x) up a positive roll."""
    x = np.zeros(19)
    x[3:7] = np.roll(Rotation.from_euler("x", 10, degrees=True).as_quat(), 1)  # z_A to -y
    assert np.degrees(am.pitch_roll(x, np.array([0.0, -1.0, 0.0]))[0]) == pytest.approx(
        [10.0, 0.0], abs=1e-9)
    x[3:7] = np.roll(Rotation.from_euler("z", 10, degrees=True).as_quat(), 1)  # x_A to +y
    assert np.degrees(am.pitch_roll(x, np.array([0.0, -1.0, 0.0]))[0]) == pytest.approx(
        [0.0, 10.0], abs=1e-9)


def test_paper_pitch_roll_is_exact_for_a_level_head_only():
    """Eq. 22 subtracts angles: exact with the head level, a roll error of ~1.1 deg (twice the
    measurement's sigma) once the head pitches 10 deg with the remote rolled 15 deg."""
    yaw = Rotation.from_euler("y", 1.2)
    R_IA = Rotation.from_euler("x", 20, degrees=True) * Rotation.from_euler("z", 15,
                                                                           degrees=True)
    x = np.zeros(19)
    x[3:7] = np.roll(R_IA.as_quat(), 1)
    err = {}
    for pitch_deg in (0.0, 10.0):
        R_WI = yaw * Rotation.from_euler("x", pitch_deg, degrees=True)
        f_A = (R_WI * R_IA).inv().apply(-GRAVITY_W)
        z, d_I = am.pitch_roll_measurement(f_A, R_WI.as_matrix(), "paper")
        err[pitch_deg] = np.degrees(np.abs(am.pitch_roll(x, d_I)[0] - z))
    assert err[0.0].max() < 1e-9
    assert err[10.0][0] < 1e-9 and 0.8 < err[10.0][1] < 1.5


def test_static_gate_compares_vectors_in_the_head_frame_in_g():
    R_WI = Rotation.random(random_state=3).as_matrix()
    R_IA = Rotation.random(random_state=4).as_matrix()
    up_A = (R_WI @ R_IA).T @ (-GRAVITY_W)
    assert am.accel_is_static(up_A * 1.019, R_IA, R_WI)
    assert not am.accel_is_static(up_A * 1.03, R_IA, R_WI)
    side = np.cross(up_A, [1.0, 0.0, 0.0])
    side *= 0.03 * am.G0 / np.linalg.norm(side)  # sideways: the norm barely changes
    assert not am.accel_is_static(up_A + side, R_IA, R_WI)
    tilt = Rotation.from_rotvec([np.radians(1.5), 0, 0]).as_matrix()
    assert not am.accel_is_static(up_A, R_IA @ tilt, R_WI)  # 1.5 deg off: 0.026 g


def test_start_pose_matches_gravity_and_points_ahead():
    for seed in range(4):
        R_WI = Rotation.from_euler("yxz", np.random.default_rng(seed).uniform(-0.4, 0.4, 3))
        R_WA_true = Rotation.random(random_state=seed)
        f_A = R_WA_true.inv().apply(-GRAVITY_W)
        R_IA = quat.to_matrix(am.start_pose(f_A, R_WI.as_matrix()))
        # the accelerometer's up maps onto the head's up
        np.testing.assert_allclose(R_IA @ f_A, R_WI.inv().apply(-GRAVITY_W), atol=1e-9)
        # the pointing axis and the optical axis have the same azimuth in W (about y)
        z_W = (R_WI.as_matrix() @ R_IA)[:, 2]
        o_W = R_WI.as_matrix()[:, 2]
        assert abs(np.arctan2(z_W[0], z_W[2]) - np.arctan2(o_W[0], o_W[2])) < 1e-9
    # a level head and a remote held level ahead: the identity
    q = am.start_pose(-GRAVITY_W, np.eye(3))
    np.testing.assert_allclose(np.abs(q), [1, 0, 0, 0], atol=1e-12)
    assert UP @ (-GRAVITY_W) > 0
