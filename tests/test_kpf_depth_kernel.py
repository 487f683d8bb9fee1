"""The compiled kept wrist range (``kpf/depth_kernel.py``) against its numpy reference
(``keep_wrist_range``: numpy, ``rotation_between``, scipy's Euler angles in
``shoulder_angles``), and its pieces against scipy; ``shoulder_angles``' shortcut past scipy's
matrix validation against the validated path."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import camera, facing_arm_poses
from scipy.spatial.transform import Rotation

from humimic.bodymodel.avatar import _arm_limits, rotations_from_matrices, shoulder_angles
from humimic.bodymodel.kinematics import ARM_AXES, shoulder_rotation
from humimic.maths.rotations import rotation_between
from humimic.perception.trackers.kpf.depth import SIDES, keep_wrist_range, kept_ranges
from humimic.perception.trackers.kpf.depth_kernel import _rotation_between, _shoulder_angles
from humimic.perception.trackers.kpf.tracker import kpf_body


@pytest.mark.parametrize("clip", [True, False])
def test_kept_ranges_equal_the_numpy_reference_per_arm(clip):
    """Both arms, a random subset of the rows (``rows`` and ``share`` < 1, the same draws):
    every row the reference moves, the kernel moves to the same state (rounding: measured
    1.3e-14 here and on the bench's frames), and it leaves the others alone."""
    body = kpf_body()
    rng = np.random.default_rng(11)
    n = 300
    q = facing_arm_poses(body, rng, n, [-0.3, 0.1, -0.5, 0.3] * 2, [1.4, 1.6, 0.5, 1.8] * 2,
                         slice(6, 14))
    q[:, :6] += rng.uniform(-0.05, 0.05, (n, 6))
    q = body.free_limits.clamp(q)
    ref = body.free_limits.clamp(q + rng.uniform(-0.3, 0.3, q.shape) * (np.arange(14) >= 6))
    rows = rng.random(n) < 0.8
    T = camera()
    got = kept_ranges(body, q, ref, rows, 0.7, T, clip, np.random.default_rng(5))
    want = q.copy()
    draws = np.random.default_rng(5)
    for side in SIDES:
        pick = np.flatnonzero(rows & (draws.random(n) < 0.7))
        want[pick] = keep_wrist_range(body, want[pick], ref[pick], side, T, clip)
    moved = np.any(want != q, axis=1)
    assert 0.5 < moved.mean() < 0.9                      # measured 0.69-0.70
    np.testing.assert_allclose(got, want, rtol=0, atol=5e-14)
    assert np.array_equal(np.any(got != q, axis=1), moved)


def test_rotation_between_kernel_matches_the_numpy_one_and_the_half_turn():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(100, 3)), rng.normal(size=(100, 3))
    a[0], b[0] = [1.0, 0, 0], [-2.0, 0, 0]              # opposite: a half turn
    a[1], b[1] = [0, 1.0, 0], [0, 3.0, 0]               # the same direction: identity
    want = rotation_between(a, b)
    out = np.empty((3, 3))
    for k in range(len(a)):
        _rotation_between(a[k], b[k], out)
        np.testing.assert_allclose(out, want[k], atol=2e-15)   # measured 4.4e-16
    _rotation_between(a[0], b[0], out)
    assert np.linalg.det(out) == pytest.approx(1.0)


@pytest.mark.parametrize("side", ["R", "L"])
def test_shoulder_angles_kernel_matches_scipys_and_rebuilds_the_rotation(side):
    """Random rotations and some at gimbal lock (SAA = +-90 deg, an arm straight out to the
    side): the kernel's angles equal ``shoulder_angles``' (scipy's Euler angles) away from
    gimbal lock and, everywhere, rebuild the rotation (the closed form, independent of both),
    to rounding (measured 8.9e-16 and 9.4e-16)."""
    rng = np.random.default_rng(3)
    R = Rotation.random(200, random_state=4).as_matrix()
    sfe, hr = rng.uniform(-1, 1, (2, 20))
    gimbal = np.stack([shoulder_rotation(side, sfe[k], s * np.pi / 2, hr[k])
                       for k, s in enumerate(np.repeat([-1.0, 1.0], 10))])
    R = np.concatenate([R, gimbal])
    want = shoulder_angles(R, side)
    signs = np.array([s for _, s in ARM_AXES[side][:3]], float)
    lim = _arm_limits(side)
    got = np.empty((len(R), 3))
    for k in range(len(R)):
        _shoulder_angles(R[k], signs, lim.lower, lim.upper, got[k])
    np.testing.assert_allclose(got[:200], want[:200], atol=3e-15)
    rebuilt = np.stack([shoulder_rotation(side, *g) for g in got])
    np.testing.assert_allclose(rebuilt, R, atol=3e-15)


def test_rotations_from_matrices_skips_validation_only_for_rotations():
    """Proper orthonormal matrices: scipy's result bit for bit; a skewed matrix and a
    reflection get scipy's validation (orthogonalised; rejected)."""
    R = Rotation.random(50, random_state=1).as_matrix() @ Rotation.random(
        50, random_state=2).as_matrix()
    assert np.array_equal(rotations_from_matrices(R).as_quat(),
                          Rotation.from_matrix(R).as_quat())
    skew = R.copy()
    skew[0, 0, 1] += 1e-6
    np.testing.assert_allclose(rotations_from_matrices(skew).as_quat(),
                               Rotation.from_matrix(skew).as_quat(), atol=1e-15)
    flip = R.copy()
    flip[0] = -flip[0]
    with pytest.raises(ValueError):
        rotations_from_matrices(flip)
