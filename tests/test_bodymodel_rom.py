"""The humeral twist (``bodymodel/rom.py``) against independent computations: scipy's
smallest rotation between the hanging and the actual upper-arm axes (``align_vectors``) leaves
a rotation about the arm's own axis whose angle is the twist; the elbow's bending direction of
a clinical pose (arm abducted 90 deg in the frontal plane, externally rotated 90 deg: the
forearm points up); the soft range's log-prior in closed form; the tracker's prior term."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from humimic.bodymodel.kinematics import elbow_rotation, shoulder_rotation
from humimic.bodymodel.rom import (
    TWIST_RANGE_DEG,
    arm_twist_log_prior,
    humeral_twist,
    twist_log_prior,
)


def _scipy_twist(R: np.ndarray) -> float:
    """Twist of ``R_torso_upper`` about the arm's axis: ``R_swing^T R`` with scipy's smallest
    rotation taking the hanging axis -z onto the arm's, read as a rotation vector along z."""
    axis = R @ np.array([0.0, 0.0, -1.0])
    swing, _ = Rotation.align_vectors([axis], [[0.0, 0.0, -1.0]])
    rv = (swing.inv() * Rotation.from_matrix(R)).as_rotvec()
    assert np.allclose(rv[:2], 0.0, atol=1e-6)          # a pure rotation about the arm's axis
    return rv[2]


def test_twist_is_the_rotation_left_after_the_smallest_swing():
    rng = np.random.default_rng(5)
    for side, s in (("R", 1.0), ("L", -1.0)):
        a = rng.uniform([-0.8, -0.3, -1.5], [2.5, 2.5, 1.5], (200, 3))
        R = shoulder_rotation(side, *a.T)
        ok = np.einsum("nij,j->ni", R, [0, 0, -1.0])[:, 2] > -0.99  # away from the swing's pole
        got = humeral_twist(side, *a[ok].T)
        want = np.array([s * _scipy_twist(r) for r in R[ok]])
        d = (got - want + np.pi) % (2 * np.pi) - np.pi
        np.testing.assert_allclose(d, 0.0, atol=1e-9)


def test_twist_at_rest_is_hr_and_a_raised_external_turn_points_the_forearm_up():
    hr = np.radians([-50.0, 0.0, 30.0])
    for side in ("R", "L"):
        np.testing.assert_allclose(humeral_twist(side, 0.0, 0.0, hr), hr, atol=1e-12)
    # right arm abducted 90 deg sideways (SAA), then turned about its own axis until the bent
    # forearm points up: that turn is a clinical external rotation of 90 deg
    for hr_deg in np.linspace(-180.0, 180.0, 73):
        R = shoulder_rotation("R", 0.0, np.pi / 2, np.radians(hr_deg))
        f = R @ elbow_rotation("R", np.pi / 2) @ np.array([0.0, 0.0, -1.0])
        if f[2] > 0.999:                                  # forearm straight up (torso z)
            np.testing.assert_allclose(humeral_twist("R", 0.0, np.pi / 2, np.radians(hr_deg)),
                                       np.radians(-90.0), atol=1e-9)
            break
    else:
        raise AssertionError("no HR turns the forearm up")


def test_soft_range_log_prior_in_closed_form():
    lo, hi = np.radians(TWIST_RANGE_DEG)
    sd = np.radians(10.0)
    x = np.radians([-120.0, -90.0, 0.0, 70.0, 90.0])
    want = [-0.5 * 3.0 ** 2, 0.0, 0.0, 0.0, -0.5 * 2.0 ** 2]
    np.testing.assert_allclose(twist_log_prior(x, lo, hi, sd), want, atol=1e-12)


def test_arm_prior_fades_towards_the_overhead_pole():
    """In full up to 135 deg of swing from the hanging axis (measured by scipy), faded
    quadratically in 1 + cos(swing) to nothing straight up (where the twist is undefined: at
    178 deg of elevation +-10 deg of abduction turn it by ~+-157 deg, 22-38 nats unfaded; 0.1
    faded)."""
    lo, hi = np.radians(TWIST_RANGE_DEG)
    sd = np.radians(10.0)
    rng = np.random.default_rng(8)
    a = rng.uniform([-0.8, -0.3, -2.5], [3.1, 2.5, 2.5], (100, 3))
    for side in ("R", "L"):
        R = shoulder_rotation(side, *a.T)
        axis = np.einsum("nij,j->ni", R, [0, 0, -1.0])
        swing = np.array([Rotation.align_vectors([x], [[0.0, 0.0, -1.0]])[0].magnitude()
                          for x in axis])
        fade = np.minimum((1 + np.cos(swing)) / (1 + np.cos(np.radians(135.0))), 1.0) ** 2
        assert (fade == 1.0).mean() > 0.5 and (fade < 0.5).any()   # both regimes drawn
        want = fade * twist_log_prior(humeral_twist(side, *a.T), lo, hi, sd)
        np.testing.assert_allclose(arm_twist_log_prior(side, *a.T, lo, hi, sd), want,
                                   atol=1e-9)
    up = arm_twist_log_prior("R", np.radians(178.0), np.radians([-10.0, 10.0]), 0.0, lo, hi, sd)
    assert np.all(up > -0.3)                               # unfaded: -22 and -38 nats
    assert np.all(twist_log_prior(humeral_twist("R", np.radians(178.0), np.radians(
        [-10.0, 10.0]), 0.0), lo, hi, sd) < -20.0)


def test_tracker_arm_prior_penalises_each_arm_by_its_own_twist():
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
    from humimic.sensors.camera_model import Intrinsics

    intr = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)
    q = np.zeros((3, 14))
    q[1, 8] = np.radians(-110.0)                         # right arm: 20 deg beyond external
    q[2, 12] = np.radians(85.0)                          # left arm: 15 deg beyond internal
    off = KpfTracker(kpf_body(), intr, KpfConfig(), np.random.default_rng(0))
    np.testing.assert_array_equal(off._arm_prior(q), 0.0)
    on = KpfTracker(kpf_body(), intr, KpfConfig(twist_range_deg=(-90.0, 70.0)),
                    np.random.default_rng(0))
    np.testing.assert_allclose(on._arm_prior(q), [[0, 0], [-2.0, 0], [0, -1.125]], atol=1e-9)
