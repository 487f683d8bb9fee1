"""The kpf's velocity gate (:mod:`humimic.perception.trackers.kpf.velocity_gate`,
``KpfConfig.velocity_gate_px``): the arm's image motion against a pinhole projection written
out here, and which DOFs the gate zeroes."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, static_pose

from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.perception.trackers.kpf.velocity_gate import arm_image_motion, gated_velocity


def pinhole(p_base: np.ndarray, T: np.ndarray) -> np.ndarray:
    p = p_base @ T[:3, :3].T + T[:3, 3]
    return np.array([260.0 * p[0] / p[2] + 159.5, 260.0 * p[1] / p[2] + 119.5])


def test_arm_image_motion_is_the_largest_joint_displacement():
    body, T = kpf_body(), camera()
    q = static_pose()
    q_prev = q.copy()
    q_prev[6:10] += [0.05, -0.04, 0.1, 0.08]          # the right arm moved, the left not
    a, b = body.forward(q[None]), body.forward(q_prev[None])
    want = max(np.linalg.norm(pinhole(a.joint(f"r_{j}")[0], T) - pinhole(b.joint(f"r_{j}")[0], T))
               for j in ("elbow", "wrist"))
    assert arm_image_motion(body, INTRINSICS, q, q_prev, "R", T) == pytest.approx(want, rel=1e-9)
    assert arm_image_motion(body, INTRINSICS, q, q_prev, "L", T) == 0.0
    assert want > 3.0                                  # a visible motion


def test_gated_velocity_zeroes_the_still_arms_only():
    body, T = kpf_body(), camera()
    q = static_pose()
    q_prev = q.copy()
    q_prev[6:10] += [0.05, -0.04, 0.1, 0.08]
    v = np.arange(1.0, 15.0)
    moved = arm_image_motion(body, INTRINSICS, q, q_prev, "R", T)
    out = gated_velocity(body, INTRINSICS, q, q_prev, v, T, moved - 1.0)
    assert np.array_equal(out[:10], v[:10]) and np.all(out[10:] == 0.0)
    out = gated_velocity(body, INTRINSICS, q, q_prev, np.tile(v, (3, 1)), T, moved + 1.0)
    assert np.all(out[:, 6:] == 0.0) and np.array_equal(out[:, :6], np.tile(v[:6], (3, 1)))
    assert np.array_equal(v, np.arange(1.0, 15.0))        # the input untouched


def test_config_checks_the_gate():
    assert KpfConfig().velocity_gate_px is None
    with pytest.raises(ValueError, match="velocity_gate_px"):
        KpfConfig(velocity_gate_px=0.0)
