"""Every analytic Jacobian of the EKF SLAM against central finite differences, and each model
against an independent computation: scipy's rotations, OpenCV's projection, and a direct
transcription of Sugiyama eqs. 3-4 written here with its noise inputs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.estimation.ekf import inverse_depth as idp
from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import quaternion as qj
from humimic.motion import quat
from humimic.sensors.camera_model import Intrinsics

INTR = Intrinsics(368, 240, 300.0, 302.0, 183.5, 119.5, -0.12, 0.03)
#: The paper's interface frame I (x left, y up) to OpenCV's camera axes.
R_CV_I = np.diag([-1.0, -1.0, 1.0])


def numjac(f, x, eps=1e-6):
    """Central differences of ``f`` at ``x``: ``(*f(x).shape, len(x))``."""
    x = np.asarray(x, float)
    cols = []
    for i in range(len(x)):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((np.asarray(f(x + d)) - np.asarray(f(x - d))) / (2 * eps))
    return np.stack(cols, axis=-1)


def rand_quat(rng):
    return quat.normalize(rng.standard_normal(4))


def xyzw(q):
    return np.r_[q[1:], q[0]]


@pytest.fixture
def rng():
    return np.random.default_rng(11)


def test_quaternion_jacobians(rng):
    for _ in range(5):
        q, r, v = rand_quat(rng), rand_quat(rng), rng.standard_normal(3)
        np.testing.assert_allclose(qj.left(q) @ r, quat.mul(q, r), atol=1e-12)
        np.testing.assert_allclose(qj.right(r) @ q, quat.mul(q, r), atol=1e-12)
        # R(q) v for an unnormalised q is what the formula differentiates: keep q on the sphere
        # by differentiating the bilinear form directly (to_matrix normalises)
        rot = lambda qq, vv=v: vv + 2 * qq[0] * np.cross(qq[1:], vv) + 2 * np.cross(  # noqa: E731
            qq[1:], np.cross(qq[1:], vv))
        np.testing.assert_allclose(rot(q), Rotation.from_quat(xyzw(q)).apply(v), atol=1e-12)
        np.testing.assert_allclose(qj.d_rotate_dq(q, v), numjac(rot, q), atol=1e-7)
        rotT = lambda qq, vv=v, rot=rot: rot(np.r_[qq[0], -qq[1:]], vv)  # noqa: E731
        np.testing.assert_allclose(rotT(q), Rotation.from_quat(xyzw(q)).inv().apply(v),
                                   atol=1e-12)
        np.testing.assert_allclose(qj.d_rotate_T_dq(q, v), numjac(rotT, q), atol=1e-7)
        # batched vectors
        V = rng.standard_normal((4, 3))
        np.testing.assert_allclose(qj.d_rotate_dq(q, V)[2], qj.d_rotate_dq(q, V[2]))
        np.testing.assert_allclose(qj.d_normalize(2.5 * q), numjac(quat.normalize, 2.5 * q),
                                   atol=1e-7)
    for theta in (rng.standard_normal(3), 1e-8 * rng.standard_normal(3), np.zeros(3)):
        np.testing.assert_allclose(quat.from_rotvec(theta),
                                   xyzw_to_wxyz(Rotation.from_rotvec(theta).as_quat()),
                                   atol=1e-12)
        np.testing.assert_allclose(qj.d_rotvec_to_quat(theta),
                                   numjac(quat.from_rotvec, theta, 1e-5), atol=1e-7)


def test_scalar_rotation_helpers_match_batched(rng):
    for _ in range(50):
        q = rand_quat(rng)
        R = quat.to_matrix(q)
        np.testing.assert_allclose(mm.rotmat(q), R, atol=1e-14)
        np.testing.assert_allclose(mm.quat_from_matrix(R), quat.from_matrix(R), atol=1e-12)


def xyzw_to_wxyz(q):
    return np.r_[q[3], q[:3]]


def sugiyama_eq3(x, n, dt):
    """Sugiyama eqs. 3-4 transcribed with the noise ``n = (j, α, b̄)``; ω in the body frame,
    eq. 4's cross products in W (see motion_model's docstring). Uses scipy's rotations."""
    p, q, v, w, a, b = x[0:3], x[3:7], x[7:10], x[10:13], x[13:16], x[16:19]
    j, alpha, bdot = n[0:3], n[3:6], n[6:9]
    R = Rotation.from_quat(xyzw(q / np.linalg.norm(q)))
    ap = j + np.cross(R.apply(alpha), v) + np.cross(R.apply(w), a)  # eq. 4
    theta = w * dt + dt**2 / 2 * alpha
    dq = xyzw_to_wxyz(Rotation.from_rotvec(theta).as_quat())
    if dq[0] * np.cos(np.linalg.norm(theta) / 2) < 0:
        dq = -dq
    return np.concatenate([
        p + v * dt + dt**2 / 2 * a + dt**3 / 6 * ap,
        quat.mul(q, dq),
        v + a * dt + dt**2 / 2 * ap,
        w + alpha * dt,
        a + ap * dt,
        b + bdot * dt,
    ])


@pytest.mark.parametrize("dt", [1 / 180, 1 / 30, 0.2])
def test_motion_model_against_transcription(rng, dt):
    for _ in range(4):
        x = mm.initial_state(rng.standard_normal(3), rand_quat(rng), rng.standard_normal(3),
                             2 * rng.standard_normal(3), 3 * rng.standard_normal(3),
                             0.1 * rng.standard_normal(3))
        x_new, F, G = mm.predict(x, dt)
        np.testing.assert_allclose(x_new, sugiyama_eq3(x, np.zeros(9), dt), atol=1e-12)
        F_num = numjac(lambda xx: sugiyama_eq3(xx, np.zeros(9), dt), x)
        G_num = numjac(lambda nn, xx=x: sugiyama_eq3(xx, nn, dt), np.zeros(9))
        # d/dq of the transcription includes the normalisation of q: compare on the tangent
        # of the unit sphere (what an update can change), i.e. after projecting q's columns
        Pq = np.eye(19)
        Pq[3:7, 3:7] = qj.d_normalize(x[3:7])
        np.testing.assert_allclose(F @ Pq, F_num @ Pq, atol=1e-6 * max(1, dt * 100))
        np.testing.assert_allclose(G, G_num, atol=1e-8)


def test_process_noise_is_jerk_integrated(rng):
    """With ω = 0 the translational block is the discrete jerk model: ``σ_j^2 g g^T`` with
    ``g = (dt^3/6, dt^2/2, dt)`` per axis (Armesto et al. 2007)."""
    dt = 1 / 180
    x = mm.initial_state(q=rand_quat(rng))
    _, _, G = mm.predict(x, dt)
    Q = mm.process_noise(G, mm.MotionNoise())
    g = np.array([dt**3 / 6, dt**2 / 2, dt])
    for i, ci in enumerate((mm.P, mm.V, mm.A)):
        for k, ck in enumerate((mm.P, mm.V, mm.A)):
            np.testing.assert_allclose(Q[ci, ck], 15.0**2 * g[i] * g[k] * np.eye(3),
                                       rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(Q[mm.W, mm.W], (15.0 * dt) ** 2 * np.eye(3))
    np.testing.assert_allclose(Q[mm.B, mm.B], (1e-3 * dt) ** 2 * np.eye(3))


def test_project_jacobian_against_opencv(rng):
    """OpenCV's projectPoints Jacobian with respect to the translation is the Jacobian with
    respect to the camera-frame point when the rotation is zero."""
    pts = np.c_[rng.uniform(-1, 1, (6, 2)), rng.uniform(1.5, 4, 6)]
    for intr in (INTR, INTR.pinhole()):
        for p in pts:
            uv, J = cv2.projectPoints(np.zeros((1, 3)), np.zeros(3), p, intr.K, intr.dist)
            np.testing.assert_allclose(intr.project(np.zeros(3) + p), uv[0, 0], atol=1e-9)
            np.testing.assert_allclose(intr.project_jacobian(p), J[:, 3:6], rtol=1e-7,
                                       atol=1e-7)
            np.testing.assert_allclose(intr.project_jacobian(p), numjac(intr.project, p),
                                       atol=1e-5)


def _id_feature(rng):
    th, ph = rng.uniform(-1, 1), rng.uniform(-0.5, 0.5)
    return np.r_[rng.standard_normal(3) * 0.3, th, ph, rng.uniform(0.2, 1.0)]


def _pose_looking_at(rng, target):
    """A pose 3 m behind ``target`` along W's z, I's z (the optical axis) towards it."""
    p = target + np.r_[rng.uniform(-0.5, 0.5, 2), -3.0]
    q = xyzw_to_wxyz(Rotation.from_rotvec(0.1 * rng.standard_normal(3)).as_quat())
    return p, q


def test_observe_against_opencv_and_numerical(rng):
    intr = INTR.pinhole()
    for _ in range(5):
        y = _id_feature(rng)
        X = idp.to_xyz(y[None])[0][0]
        p, q = _pose_looking_at(rng, X)
        # OpenCV: rvec/tvec map W to the camera: x_C = R_cv_I R^T (x_W - p)
        R_cw = Rotation.from_matrix(R_CV_I) * Rotation.from_quat(xyzw(q)).inv()
        rvec = R_cw.as_rotvec()
        tvec = -R_cw.apply(p)
        uv_cv = cv2.projectPoints(X[None], rvec, tvec, intr.K, None)[0][0, 0]
        for yy in (y, X):
            h, Hpq, Hy, z = idp.observe(yy[None], p, q, intr, R_CV_I)
            assert z[0] > 0
            np.testing.assert_allclose(h[0], uv_cv, atol=1e-8)
            pq = np.r_[p, q]
            num_pq = numjac(lambda v, yy=yy: idp.observe(  # noqa: E731
                yy[None], v[:3], v[3:], intr, R_CV_I)[0][0], pq)
            # q enters through R(q) for a unit q; compare along the sphere's tangent
            T = np.eye(7)
            T[3:, 3:] = qj.d_normalize(q)
            np.testing.assert_allclose(Hpq[0] @ T, num_pq @ T, rtol=1e-5, atol=1e-4)
            num_y = numjac(lambda v, p=p, q=q: idp.observe(v[None], p, q, intr, R_CV_I)[0][0],
                           yy)
            np.testing.assert_allclose(Hy[0], num_y, rtol=1e-5, atol=1e-4)


def test_inverse_depth_conversion_and_linearity(rng):
    Y = np.stack([_id_feature(rng) for _ in range(4)])
    X, J = idp.to_xyz(Y)
    for i in range(4):
        np.testing.assert_allclose(J[i], numjac(lambda v: idp.to_xyz(v[None])[0][0], Y[i]),
                                   atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(X[i] - Y[i, :3]), 1 / Y[i, 5])
    th, ph, Ja = idp.angles(X - Y[:, :3])
    np.testing.assert_allclose(th, Y[:, 3])
    np.testing.assert_allclose(ph, Y[:, 4])
    for i in range(4):
        f = lambda h: np.array(idp.angles(h[None])[:2])[:, 0]  # noqa: E731
        np.testing.assert_allclose(Ja[i], numjac(f, X[i] - Y[i, :3]), atol=1e-7)
    # the linearity index falls with parallax and with depth certainty
    y = np.array([[0, 0, 0, 0.0, 0.0, 0.25]])  # a point 4 m ahead
    no_parallax = idp.linearity_index(y, np.array([0.05]), np.zeros(3))
    parallax = idp.linearity_index(y, np.array([0.05]), np.array([2.0, 0, 0]))
    certain = idp.linearity_index(y, np.array([0.005]), np.array([2.0, 0, 0]))
    assert no_parallax > parallax > certain
    np.testing.assert_allclose(no_parallax, 4 * 0.05 / 0.25**2 / 4.0)


def test_initialise_back_projects_and_jacobians(rng):
    intr = INTR.pinhole()
    uv = np.array([[30.0, 40.0], [183.5, 119.5], [350.0, 220.0]])
    p, q = rng.standard_normal(3), rand_quat(rng)
    y, J_pq, J_z = idp.initialise(uv, p, q, intr, R_CV_I, rho0=0.4)
    h, *_ = idp.observe(y, p, q, intr, R_CV_I)
    np.testing.assert_allclose(h, uv, atol=1e-9)  # the new ray goes through its pixel
    np.testing.assert_allclose(np.linalg.norm(idp.to_xyz(y)[0] - p, axis=1), 2.5)
    for i in range(3):
        T = np.eye(7)
        T[3:, 3:] = qj.d_normalize(q)
        f = lambda v, i=i: idp.initialise(  # noqa: E731
            uv[i:i + 1], v[:3], v[3:], intr, R_CV_I, 0.4)[0][0]
        np.testing.assert_allclose(J_pq[i] @ T, numjac(f, np.r_[p, q]) @ T, atol=1e-6)
        g = lambda z, i=i, p=p, q=q: idp.initialise(  # noqa: E731
            z[None, :2], p, q, intr, R_CV_I, z[2])[0][0]
        np.testing.assert_allclose(J_z[i], numjac(g, np.r_[uv[i], 0.4]), atol=1e-6)


def test_undistortion_maps_invert_the_distortion():
    map_x, map_y = INTR.undistortion_maps()
    for u, v in ((10, 12), (183, 119), (360, 230)):
        ray = np.array([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, 1.0])
        # float32 maps: measured <= 1.1e-5 px and 4.3e-8 (half a float32 ulp at 360 px is 1.5e-5;
        # 2026-11-29; the bounds were 1e-3 and 1e-5)
        np.testing.assert_allclose([map_x[v, u], map_y[v, u]], INTR.project(ray), atol=4e-5)
        back = INTR.undistort_normalized(np.array([map_x[v, u], map_y[v, u]], float))
        np.testing.assert_allclose(back, ray[:2], atol=1.5e-7)


def test_specific_force_model_against_scipy_and_numerical(rng):
    """``h = R(q)^T (a + b - g)``: the reading of an accelerometer (scipy's rotation of the
    world-frame specific force into the sensor), with ``dh/dx`` by finite differences."""
    g = np.array([0.0, -9.81, 0.0])
    x = mm.initial_state(p=rng.normal(size=3), q=quat.normalize(rng.normal(size=4)),
                         v=rng.normal(size=3), w=rng.normal(size=3), a=rng.normal(size=3),
                         b=0.1 * rng.normal(size=3))
    h, H = mm.h_specific_force(x, g)
    w, xq, yq, zq = x[3:7]
    R_WI = Rotation.from_quat([xq, yq, zq, w])  # scipy: scalar last
    np.testing.assert_allclose(h, R_WI.inv().apply(x[13:16] + x[16:19] - g), atol=1e-12)
    np.testing.assert_allclose(H, numjac(lambda y: mm.h_specific_force(y, g)[0], x),
                               atol=1e-6)
