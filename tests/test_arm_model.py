"""Sugiyama's motion model (eqs. 3-4) and arm measurement models (eqs. 12-24): analytic
Jacobians vs finite differences, values vs scipy, OpenCV and closed forms."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.estimation.ekf import arm_model as am
from humimic.estimation.ekf.jerk_model import (
    DIM,
    A,
    JerkNoise,
    P,
    Q,
    V,
    W,
    jacobians,
    normalize_quaternion,
    predict,
    predict_state,
)
from humimic.maths.kinematics import ca_predict
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics

K = Intrinsics.from_fovy(np.radians(45.0), 368, 240)
#: A 4 x 3 cm marker face in A, corners in order around it.
CORNERS = np.array([[-0.02, -0.015, 0.0], [0.02, -0.015, 0.0], [0.02, 0.015, 0.0],
                    [-0.02, 0.015, 0.0]])


def random_state(rng, moving=True) -> np.ndarray:
    x = np.zeros(DIM)
    x[P] = [rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.3), rng.uniform(0.4, 0.8)]
    x[Q] = quat.normalize(np.array([1.0, 0, 0, 0]) + 0.3 * rng.normal(size=4))
    if moving:
        x[V] = rng.normal(scale=0.5, size=3)
        x[W] = rng.normal(scale=1.0, size=3)
        x[A] = rng.normal(scale=2.0, size=3)
        x[16:19] = rng.normal(scale=0.1, size=3)
    return x


def numeric_jacobian(f, x, eps=1e-7):
    f0 = np.atleast_1d(f(x))
    J = np.empty((len(f0), len(x)))
    for i in range(len(x)):
        d = np.zeros(len(x))
        d[i] = eps
        J[:, i] = (np.atleast_1d(f(x + d)) - np.atleast_1d(f(x - d))) / (2 * eps)
    return J


@pytest.mark.parametrize("dt", [0.01, 1 / 30])
def test_motion_jacobians_match_finite_differences(dt):
    rng = np.random.default_rng(1)
    for _ in range(5):
        x = random_state(rng)
        F, G = jacobians(x, dt)
        np.testing.assert_allclose(F, numeric_jacobian(lambda y: predict_state(y, dt), x),
                                   atol=1e-7)
        Gn = numeric_jacobian(lambda n, x=x: predict_state(x, dt, n), np.zeros(9))
        np.testing.assert_allclose(G, Gn, atol=1e-8)


def test_motion_jacobian_near_zero_rotation():
    x = random_state(np.random.default_rng(2))
    x[W] = [1e-9, -2e-9, 0.0]
    F, _ = jacobians(x, 0.01)
    np.testing.assert_allclose(F, numeric_jacobian(lambda y: predict_state(y, 0.01), x),
                               atol=1e-7)


def test_prediction_matches_scipy_and_constant_acceleration():
    rng = np.random.default_rng(3)
    x = random_state(rng)
    dt = 0.05
    y = predict_state(x, dt)
    # orientation: body-frame rotation by w dt, composed with scipy (xyzw)
    r0 = Rotation.from_quat(np.roll(x[Q], -1))
    r1 = r0 * Rotation.from_rotvec(x[W] * dt)
    q1 = np.roll(r1.as_quat(), 1)
    assert min(np.abs(y[Q] - q1).max(), np.abs(y[Q] + q1).max()) < 1e-12
    # without rotation, eq. 3's translation is constant acceleration (maths.kinematics)
    x[W] = 0.0
    y = predict_state(x, dt)
    p, v, a = ca_predict(x[P], x[V], x[A], dt)
    np.testing.assert_allclose(np.concatenate([y[P], y[V], y[A]]), np.concatenate([p, v, a]),
                               atol=1e-14)
    # with rotation, eq. 4's deterministic jerk is the rate (in the parent frame) x a
    x = random_state(rng)
    y = predict_state(x, dt)
    jerk = np.cross(r0_apply(x, x[W]), x[A])
    np.testing.assert_allclose(y[A], x[A] + jerk * dt, atol=1e-12)


def r0_apply(x, v):
    return Rotation.from_quat(np.roll(x[Q], -1)).apply(v)


def test_process_noise_matches_monte_carlo():
    """The linearised covariance step against sampled noise through the nonlinear model."""
    rng = np.random.default_rng(4)
    x = random_state(rng)
    noise, dt = JerkNoise(), 0.02
    _, P1 = predict(x, np.zeros((DIM, DIM)), dt, noise)
    n = rng.normal(size=(5000, 9)) * np.sqrt(np.diag(noise.covariance()))
    ys = np.array([predict_state(x, dt, ni) for ni in n])
    C = np.cov(ys.T)
    idx = np.r_[0:3, 7:16]  # position, velocity, rate, acceleration
    np.testing.assert_allclose(np.diag(C)[idx], np.diag(P1)[idx], rtol=0.08)


def test_normalize_quaternion_keeps_unit_and_covariance_tangent():
    rng = np.random.default_rng(5)
    x = random_state(rng)
    x[Q] *= 1.3
    Pc = np.eye(DIM) * 0.01
    x2, P2 = normalize_quaternion(x, Pc)
    assert abs(np.linalg.norm(x2[Q]) - 1) < 1e-14
    assert abs(x2[Q] @ P2[Q, Q] @ x2[Q]) < 1e-12  # no variance along q itself


def test_centroid_matches_opencv_and_jacobian():
    rng = np.random.default_rng(6)
    x = random_state(rng)
    uv, H = am.centroid(x, K)
    uv_cv, _ = cv2.projectPoints(x[P][None], np.zeros(3), np.zeros(3), K.K, None)
    np.testing.assert_allclose(uv, uv_cv.ravel(), atol=1e-9)
    np.testing.assert_allclose(H, numeric_jacobian(lambda y: am.centroid(y, K)[0], x),
                               atol=1e-5)


def test_area_matches_opencv_contour_area_and_jacobian():
    rng = np.random.default_rng(7)
    for _ in range(5):
        x = random_state(rng)
        area, H = am.marker_area(x, K, CORNERS)
        R = quat.to_matrix(x[Q])
        pts = x[P] + CORNERS @ R.T
        uv, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K.K, None)
        assert area == pytest.approx(cv2.contourArea(uv.reshape(4, 2).astype(np.float32)),
                                     rel=1e-5)
        Hn = numeric_jacobian(lambda y: am.marker_area(y, K, CORNERS)[0], x, eps=1e-6)
        np.testing.assert_allclose(H[0], Hn[0], rtol=1e-4, atol=1e-3)


def test_area_of_facing_marker_is_the_pinhole_closed_form():
    x = np.zeros(DIM)
    x[P], x[Q] = [0.0, 0.0, 0.6], [1.0, 0, 0, 0]
    area, _ = am.marker_area(x, K, CORNERS)
    assert area == pytest.approx(K.fx * K.fy * 0.04 * 0.03 / 0.6**2)


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


def test_pitch_roll_jacobian_and_accelerometer_angles():
    rng = np.random.default_rng(10)
    for _ in range(5):
        x = random_state(rng)
        d = quat.normalize(rng.normal(size=3))
        h, H = am.pitch_roll(x, d)
        np.testing.assert_allclose(H, numeric_jacobian(lambda y, d=d: am.pitch_roll(y, d)[0], x),
                                   atol=1e-6)
        # gravity mode is exact: the accelerometer's angles equal the model's with the true
        # orientations, for any head orientation
        R_WI = Rotation.random(random_state=int(rng.integers(1 << 30)))
        R_IA = Rotation.from_quat(np.roll(x[Q], -1))
        f_A = (R_WI * R_IA).inv().apply([0.0, 0.0, am.G0])  # at rest: specific force up
        z, d_I = am.pitch_roll_measurement(f_A, R_WI.as_matrix(), "gravity")
        np.testing.assert_allclose(am.pitch_roll(x, d_I)[0], z, atol=1e-12)


def test_paper_pitch_roll_is_exact_for_a_level_head_only():
    """Eq. 22 subtracts angles: exact with the head level, a roll error of ~0.7 deg (more than
    the measurement's sigma) once the head pitches 10 deg with the remote rolled 15 deg."""
    rng = np.random.default_rng(11)
    yaw = Rotation.from_euler("z", rng.uniform(-3, 3))
    # the head camera looking level along the world's x: OpenCV axes x = -y_w, y = -z_w
    level = Rotation.from_matrix(np.column_stack([[0, -1, 0], [0, 0, -1], [1, 0, 0]]))
    R_IA = Rotation.from_euler("x", 20, degrees=True) * Rotation.from_euler("z", 15,
                                                                           degrees=True)
    x = np.zeros(DIM)
    x[Q] = np.roll(R_IA.as_quat(), 1)
    err = {}
    for pitch_deg in (0.0, 10.0):
        R_WI = yaw * level * Rotation.from_euler("x", -pitch_deg, degrees=True)
        f_A = (R_WI * R_IA).inv().apply([0.0, 0.0, am.G0])
        z, d_I = am.pitch_roll_measurement(f_A, R_WI.as_matrix(), "paper")
        err[pitch_deg] = np.degrees(np.abs(am.pitch_roll(x, d_I)[0] - z))
    assert err[0.0].max() < 1e-9
    assert err[10.0][0] < 1e-9 and 0.5 < err[10.0][1] < 1.0


def test_static_gate_compares_vectors_in_the_head_frame_in_g():
    R_WI = Rotation.random(random_state=3).as_matrix()
    R_IA = Rotation.random(random_state=4).as_matrix()
    up_A = (R_WI @ R_IA).T @ [0.0, 0.0, am.G0]
    assert am.accel_is_static(up_A * 1.019, R_IA, R_WI)
    assert not am.accel_is_static(up_A * 1.03, R_IA, R_WI)
    side = np.cross(up_A, [1.0, 0.0, 0.0])
    side *= 0.03 * am.G0 / np.linalg.norm(side)  # sideways: the norm barely changes
    assert not am.accel_is_static(up_A + side, R_IA, R_WI)
    tilt = Rotation.from_rotvec([np.radians(1.5), 0, 0]).as_matrix()
    assert not am.accel_is_static(up_A, R_IA @ tilt, R_WI)  # 1.5 deg off: 0.026 g


def test_start_pose_matches_gravity_and_points_ahead():
    for seed in range(4):
        R_WI = Rotation.from_euler("zyx", np.random.default_rng(seed).uniform(-0.4, 0.4, 3)) \
            * Rotation.from_matrix(np.column_stack([[0, -1, 0], [0, 0, -1], [1, 0, 0]]))
        R_WA_true = Rotation.random(random_state=seed)
        f_A = R_WA_true.inv().apply([0.0, 0.0, am.G0])
        R_IA = quat.to_matrix(am.start_pose(f_A, R_WI.as_matrix()))
        # the accelerometer's up maps onto the head's up
        np.testing.assert_allclose(R_IA @ f_A, R_WI.inv().apply([0, 0, am.G0]), atol=1e-9)
        # the pointing axis and the optical axis have the same azimuth in the world
        z_W = (R_WI.as_matrix() @ R_IA)[:, 2]
        o_W = R_WI.as_matrix()[:, 2]
        assert abs(np.arctan2(z_W[1], z_W[0]) - np.arctan2(o_W[1], o_W[0])) < 1e-9
