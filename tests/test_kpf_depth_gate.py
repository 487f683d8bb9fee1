"""The kpf's foreshortening gate on the kept wrist range (``keep_range_gate_deg``) against
closed forms: the out-of-plane angle of segments in and across the image plane, and its cosine
against a short segment's image length through the pinhole; the smooth step's ends and middle;
``kept_ranges`` leaving the gated-off rows alone; the config's validation; and the tracker with
the gate fully open or shut."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, facing_arm_poses, propagated_wrist_ranges
from pydantic import ValidationError

from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.depth import kept_ranges
from humimic.perception.trackers.kpf.depth_gate import hold_share, out_of_plane_angle
from humimic.perception.trackers.kpf.tracker import kpf_body


def test_out_of_plane_angle_in_the_plane_along_the_ray_and_at_45_deg():
    c = np.array([1.0, -2.0, 0.5])
    mid = c + np.array([0.0, 0.0, 3.0])           # the ray from c through the midpoint is +z
    d = np.array([[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.4], [0.1, 0.0, -0.1],
                  [0.0, 0.3 * np.cos(0.2), 0.3 * np.sin(0.2)]])
    theta = out_of_plane_angle(mid - d / 2, mid + d / 2, c)
    np.testing.assert_allclose(theta, [0.0, 0.0, np.pi / 2, np.pi / 4, 0.2], atol=1e-12)


def test_out_of_plane_cosine_is_a_short_segments_image_length_on_the_optical_axis():
    """On the optical axis a short segment of length L at depth z images to f L cos(theta) / z
    pixels (the pinhole's projection, computed through ``Intrinsics.project``)."""
    rng = np.random.default_rng(3)
    n, L = 200, 1e-4
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    z = rng.uniform(1.0, 4.0, n)
    mid = np.column_stack([np.zeros(n), np.zeros(n), z])
    a, b = mid - 0.5 * L * d, mid + 0.5 * L * d
    px = np.linalg.norm(INTRINSICS.project(b) - INTRINSICS.project(a), axis=1)
    assert INTRINSICS.fx == INTRINSICS.fy
    np.testing.assert_allclose(np.cos(out_of_plane_angle(a, b, np.zeros(3))),
                               px * z / (INTRINSICS.fx * L), atol=3e-9)  # measured 8.6e-10


def test_hold_share_is_whole_below_lo_none_above_hi_half_in_the_middle():
    lo, hi = np.radians(15.0), np.radians(35.0)
    theta = np.radians([0.0, 15.0, 20.0, 25.0, 30.0, 35.0, 60.0, 90.0])
    t = np.array([0.25, 0.75])                        # 20 and 30 deg
    np.testing.assert_allclose(hold_share(theta, lo, hi),
                               [1.0, 1.0, 1 - (3 * t[0] ** 2 - 2 * t[0] ** 3), 0.5,
                                1 - (3 * t[1] ** 2 - 2 * t[1] ** 3), 0.0, 0.0, 0.0],
                               atol=1e-12)


def test_kept_ranges_leave_the_gated_off_rows_alone():
    body, T = kpf_body(), camera()
    rng = np.random.default_rng(5)
    q = facing_arm_poses(body, rng, 100, [-0.3, 0.2, -0.5, 0.3], [1.2, 1.2, 0.5, 1.5])
    ref = facing_arm_poses(body, rng, 100, [-0.3, 0.2, -0.5, 0.3], [1.2, 1.2, 0.5, 1.5])
    gate = np.tile([0.0, 1.0], 50)
    out = kept_ranges(body, q, ref, np.ones(100, bool), 1.0, T, True,
                      np.random.default_rng(0), {"R": gate, "L": np.zeros(1)})
    assert np.array_equal(out[gate == 0.0], q[gate == 0.0])
    assert np.array_equal(out[:, 10:], q[:, 10:])      # the left arm's gate shut everywhere
    # measured: every gated particle moved (the bound was half)
    assert np.mean(np.any(out[gate == 1.0] != q[gate == 1.0], axis=1)) > 0.9


@pytest.mark.parametrize("gate", [(30.0, 10.0), (10.0, 10.0), (-5.0, 20.0), (10.0, 95.0)])
def test_gate_config_rejects_bad_ranges(gate):
    with pytest.raises(ValidationError, match="keep_range_gate_deg"):
        KpfConfig(keep_range_share=1.0, keep_range_gate_deg=gate)


def test_tracker_gate_open_keeps_no_range_and_shut_keeps_them_all(monkeypatch):
    """With ``keep_range_share`` 1 from the start pose (every ancestor the same, the right arm
    raised to the side, well inside 85 deg and beyond 1e-3 deg of the image plane): a gate of
    [85, 90] keeps every reachable wrist at the start pose's camera distance, [0, 1e-3] none
    (the walk's spread, as without the option)."""
    exact = {}
    for gate in ((85.0, 90.0), (0.0, 1e-3)):
        cfg = KpfConfig(n_particles=200, iterations=1, keep_range_share=1.0,
                        keep_range_gate_deg=gate)
        r, r0 = propagated_wrist_ranges(monkeypatch, cfg)
        exact[gate[0]] = np.mean(np.abs(r - r0) < 1e-6)
    assert exact[85.0] > 0.6, exact                  # measured 0.79, as ungated
    assert exact[0.0] < 0.05, exact                  # measured 0
