"""The shared scalar geometry kernels against the vectorised numpy implementations they
compile (:mod:`humimic.bodymodel.geometry_kernels` against :mod:`~humimic.bodymodel.conics`
and :mod:`~humimic.bodymodel.kinematics`; :func:`distort_point` against
:meth:`Intrinsics.distort`), on random poses, sizes and lenses, ellipsoids straddling and
behind the camera included."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.bodymodel import conics
from humimic.bodymodel.geometry_kernels import (
    axis_rotation_into,
    ellipse_axes,
    ellipsoid_ellipse,
    mat3_mul,
    ypr_into,
)
from humimic.bodymodel.kinematics import axis_rotation, ypr_matrix
from humimic.bodymodel.projection import Z_MIN
from humimic.sensors.camera_kernels import distort_point
from humimic.sensors.camera_model import Intrinsics


def test_rotations_and_product_are_kinematics():
    rng = np.random.default_rng(0)
    out, out2, prod = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for _ in range(50):
        axis, angle = int(rng.integers(3)), rng.uniform(-4, 4)
        axis_rotation_into(out, axis, angle)
        np.testing.assert_allclose(out, axis_rotation(axis, angle), rtol=0, atol=1e-15)
        yaw, pitch, roll = rng.uniform(-3, 3, 3)
        ypr_into(out2, yaw, pitch, roll)
        np.testing.assert_allclose(out2, ypr_matrix(yaw, pitch, roll), rtol=0, atol=1e-15)
        mat3_mul(out, out2, prod)
        np.testing.assert_allclose(prod, out @ out2, rtol=0, atol=1e-15)


def test_ellipsoid_ellipse_is_conics():
    rng = np.random.default_rng(1)
    n = 400
    R = Rotation.random(n, random_state=2).as_matrix()
    semi = rng.uniform(0.01, 0.3, (n, 3))
    t = np.c_[rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-0.4, 3.0, n)]   # some straddle z = 0
    A, b, c = conics.ellipsoid_quadric(R, t, semi)
    centre, M, real = conics.conic_to_ellipse(conics.quadric_to_conic(A, b, c))
    reach_z = np.linalg.norm(R[:, 2, :] * semi, axis=-1)
    expect_ok = real & (c > 0) & (t[:, 2] - reach_z > Z_MIN)
    got = np.array([ellipsoid_ellipse(R[k], t[k], semi[k], Z_MIN) for k in range(n)])
    ok = got[:, 5].astype(bool)
    np.testing.assert_array_equal(ok, expect_ok)
    assert 0.2 * n < ok.sum() < 0.95 * n            # both branches exercised
    expect = np.c_[centre, M[:, 0, 0], M[:, 0, 1], M[:, 1, 1]][ok]
    np.testing.assert_allclose(got[ok, :5], expect, rtol=1e-12, atol=1e-12)
    assert np.allclose(M[ok, 0, 1], M[ok, 1, 0])
    major, minor, angle = conics.ellipse_axes(M[ok])
    axes = np.array([ellipse_axes(*m) for m in got[ok, 2:5]])
    np.testing.assert_allclose(axes, np.c_[major, minor, angle], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("k1, k2", [(0.0, 0.0), (-0.12, 0.03), (0.08, -0.01)])
def test_distort_point_is_intrinsics_distort(k1, k2):
    intr = Intrinsics(640, 480, 520.0, 515.0, 318.5, 242.0, k1, k2)
    xy = np.random.default_rng(3).uniform(-0.7, 0.7, (100, 2))
    u, v = intr.distort(xy[:, 0], xy[:, 1])
    got = np.array([distort_point(intr.fx, intr.fy, intr.cx, intr.cy, intr.k1, intr.k2, x, y)
                    for x, y in xy])
    np.testing.assert_allclose(got, np.c_[u, v], rtol=1e-12, atol=1e-12)
