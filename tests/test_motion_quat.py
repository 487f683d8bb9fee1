"""Rotation helpers of humimic.motion.quat against scipy's Rotation (scalar-last there)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.motion import quat


def _wxyz(r: Rotation) -> np.ndarray:
    return np.roll(r.as_quat(), 1, axis=-1)


def test_matrix_product_and_rotvec_agree_with_scipy():
    rng = np.random.default_rng(0)
    a, b = Rotation.random(50, random_state=1), Rotation.random(50, random_state=2)
    qa, qb = _wxyz(a), _wxyz(b)
    np.testing.assert_allclose(quat.to_matrix(qa), a.as_matrix(), atol=1e-12)
    q_ab = quat.mul(qa, qb)
    np.testing.assert_allclose(quat.to_matrix(q_ab), (a * b).as_matrix(), atol=1e-12)
    q = quat.from_matrix(a.as_matrix())
    assert np.all(q[:, 0] >= 0)
    np.testing.assert_allclose(np.abs(np.sum(q * qa, axis=1)), 1.0, atol=1e-12)
    rv = rng.normal(size=(50, 3))
    th = np.linalg.norm(rv, axis=1)
    np.testing.assert_allclose(quat.to_matrix(quat.from_axis_angle(rv, th)),
                               Rotation.from_rotvec(rv).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(quat.angle(qa), a.magnitude(), atol=1e-9)
    np.testing.assert_allclose(quat.to_rotvec(qa), a.as_rotvec(), atol=1e-9)


def test_elementary_rotations_and_swing():
    ang = np.linspace(-3, 3, 7)
    for axis, f in zip("xyz", (quat.rot_x, quat.rot_y, quat.rot_z), strict=True):
        np.testing.assert_allclose(f(ang), Rotation.from_euler(axis, ang[:, None]).as_matrix(),
                                   atol=1e-12)
    rng = np.random.default_rng(3)
    a, b = quat.normalize(rng.normal(size=(20, 3))), quat.normalize(rng.normal(size=(20, 3)))
    R = quat.swing(a, b)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, a), b, atol=1e-12)
    # minimal: the rotation angle equals the angle between the vectors
    np.testing.assert_allclose(Rotation.from_matrix(R).magnitude(),
                               np.arccos(np.sum(a * b, axis=1)), atol=1e-9)


def test_hemisphere_continuity():
    q = _wxyz(Rotation.from_rotvec(np.outer(np.linspace(0, 1, 10), [0, 0, 1])))
    flipped = q * np.where(np.arange(10) % 3 == 0, -1.0, 1.0)[:, None]
    fixed = quat.hemisphere_continuous(flipped)
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=1) > 0)
    np.testing.assert_allclose(np.abs(fixed), np.abs(q))


def test_rotation_angle_is_scipys_magnitude():
    """The angle of rotation matrices (the arm's, SLAM's and mimicry's orientation error)
    against scipy's rotation-vector magnitude, near 0 and near pi included."""
    R = Rotation.random(500, random_state=4)
    small = Rotation.from_rotvec(np.array([[1e-3, 0, 0], [0, 0, 3.1], [0, np.pi, 0]]))
    for r in (R, small):
        np.testing.assert_allclose(quat.rotation_angle(r.as_matrix()), r.magnitude(),
                                   atol=2e-7)
    assert quat.rotation_angle(np.eye(3)) == 0.0
