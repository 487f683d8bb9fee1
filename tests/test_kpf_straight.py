"""The kpf's kept wrist range near the straight elbow (``keep_range_straight_deg``): the
re-solve of a propagated nearly straight arm whose wrist is put back at its ancestor's camera
distance bends it far more often than it straightens it (the other way is out of the arm's
reach), so over a walk's cloud it raises the mean elbow flexion; with the threshold those
rows are left as the walk put them and every other row is the plain re-solve."""

from __future__ import annotations

import numpy as np
from _kpf_synth import camera, facing_arm_poses

from humimic.perception.trackers.kpf.depth import kept_ranges, nearly_straight
from humimic.perception.trackers.kpf.tracker import kpf_body

LEFT = slice(10, 14)
L_EB, R_EB = 13, 9


def test_nearly_straight_reads_each_arms_elbow():
    q = np.zeros((3, 14))
    q[:, L_EB] = [0.1, 0.29, 0.31]
    q[:, R_EB] = 1.0
    np.testing.assert_array_equal(nearly_straight(q, "L", 0.3), [True, True, False])
    np.testing.assert_array_equal(nearly_straight(q, "R", 0.3), [False, False, False])


def _walked_hanging_left_arms(body, rng, n):
    """A random walk (+-0.2 rad) of a straight hanging left arm, the elbow clamped at its
    straight limit and above; the right arm bent 0.6-1.2 rad (above the threshold)."""
    q = facing_arm_poses(body, rng, n, [-0.2, -0.2, -0.2, -0.2], [0.2, 0.2, 0.2, 0.2], LEFT)
    q[:, 6:10] = rng.uniform([-0.3, 0.2, -0.3, 0.6], [0.3, 0.6, 0.3, 1.2], (n, 4))
    return body.free_limits.clamp(q)


def test_kept_ranges_bend_a_straight_arm_and_straight_deg_leaves_it():
    body, T = kpf_body(), camera()
    rng = np.random.default_rng(11)
    n = 400
    pred = _walked_hanging_left_arms(body, rng, n)
    ancestor = pred.copy()
    ancestor[:, LEFT] = 0.0                           # the straight hanging arm
    rows = np.ones(n, bool)
    plain = kept_ranges(body, pred, ancestor, rows, 1.0, T, True, np.random.default_rng(0))
    held = kept_ranges(body, pred, ancestor, rows, 1.0, T, True, np.random.default_rng(0),
                       straight=np.radians(20.0))
    bend = np.degrees(plain[:, L_EB] - pred[:, L_EB])
    # the plain re-solve bends most of them and straightens few (the walk's elbows: mean
    # 2.6 deg): measured the mean flexion +12.9 deg, 79 % bent and 4.8 % straightened by > 1 deg
    assert bend.mean() > 6.0 and np.mean(bend > 1.0) > 0.5 and np.mean(bend < -1.0) < 0.15
    # with the threshold (every walked left elbow is under 20 deg) the left arms stay put ...
    assert np.degrees(pred[:, L_EB]).max() < 20.0
    np.testing.assert_array_equal(held[:, LEFT], pred[:, LEFT])
    # ... and the right arm (flexed 34-69 deg, above the threshold) is as without it
    np.testing.assert_array_equal(held[:, 6:10], plain[:, 6:10])
