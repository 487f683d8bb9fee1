"""The kpf's kept wrist range near the straight elbow (``keep_range_straight_deg``): the
re-solve of a propagated straight arm whose wrist is put back at its ancestor's camera
distance can only bend it (the other way is out of the arm's reach), so over a walk's cloud
it raises the mean elbow flexion; ``unbent`` drops exactly the re-solves that bend an arm
flexed less than the threshold and leaves every other row as the plain re-solve."""

from __future__ import annotations

import numpy as np
from _kpf_synth import camera, facing_arm_poses

from humimic.perception.trackers.kpf.depth import kept_ranges, unbent
from humimic.perception.trackers.kpf.tracker import kpf_body

LEFT = slice(10, 14)
L_EB, R_EB = 13, 9


def test_unbent_keeps_the_old_row_only_where_a_nearly_straight_elbow_is_bent():
    q = np.zeros((4, 14))
    q[:, L_EB] = [0.1, 0.1, 0.5, 0.5]                 # below / below / above / above 0.3 rad
    new = q.copy()
    new[:, 10] = 1.0                                  # a moved shoulder marks the new rows
    new[:, L_EB] += [0.2, -0.05, 0.2, -0.05]          # bent / straightened, twice
    out = unbent(q, new, "L", 0.3)
    np.testing.assert_array_equal(out, np.stack([q[0], new[1], new[2], new[3]]))
    np.testing.assert_array_equal(unbent(q, new, "R", 0.3), new)   # the right elbows: 0


def _walked_hanging_left_arms(body, rng, n):
    """A random walk (+-0.2 rad) of a straight hanging left arm, the elbow clamped at its
    straight limit and above; the right arm bent 0.6-1.2 rad (away from the threshold)."""
    q = facing_arm_poses(body, rng, n, [-0.2, -0.2, -0.2, -0.2], [0.2, 0.2, 0.2, 0.2], LEFT)
    q[:, 6:10] = rng.uniform([-0.3, 0.2, -0.3, 0.6], [0.3, 0.6, 0.3, 1.2], (n, 4))
    return body.free_limits.clamp(q)


def test_kept_ranges_bend_a_straight_arm_and_straight_deg_stops_it():
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
    # with the threshold no left elbow ends more bent than the walk left it ...
    assert np.all(held[:, L_EB] <= pred[:, L_EB] + 1e-12)
    # ... and the right arm (flexed 34-69 deg, above the threshold) is as without it
    np.testing.assert_array_equal(held[:, 6:10], plain[:, 6:10])
