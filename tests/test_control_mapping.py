"""Relative-motion mapping and workspace clamping (Ude & Atkeson, relative motion)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from humimic.control.ik import build_robot_model
from humimic.control.mapping import (
    clamp_to_shell,
    map_displacement,
    mapping_matrix,
    reach_shell,
)


@pytest.fixture(scope="module")
def robot():
    m = build_robot_model()
    return m, m.key("ready").qpos.copy()


def test_relative_mode_copies_the_displacement():
    rng = np.random.default_rng(0)
    p0_h, p0_r = rng.normal(size=3), rng.normal(size=3)
    p_h = p0_h + rng.normal(size=(5, 3))
    out = map_displacement(p_h, p0_h, p0_r, mapping_matrix("relative", 1.0))
    np.testing.assert_allclose(out - p0_r, p_h - p0_h, atol=1e-15)


def test_mirrored_mode_reverses_depth_only_and_scale_scales():
    d = np.array([0.1, -0.2, 0.3])
    out = map_displacement(d, np.zeros(3), np.ones(3), mapping_matrix("mirrored", 0.5))
    np.testing.assert_allclose(out, np.ones(3) + 0.5 * np.array([-0.1, -0.2, 0.3]))


def test_mapping_at_start_gives_the_robot_start():
    p0_h, p0_r = np.array([1.3, 0.2, 0.6]), np.array([0.4, -0.25, 0.25])
    for mode in ("relative", "mirrored", "follow"):
        np.testing.assert_allclose(
            map_displacement(p0_h, p0_h, p0_r, mapping_matrix(mode, 2.0)), p0_r)


@pytest.mark.parametrize("p, expect, clamped", [
    ([0.5, 0.0, 0.0], [0.5, 0.0, 0.0], False),
    ([2.0, 0.0, 0.0], [1.0, 0.0, 0.0], True),
    ([0.0, -0.1, 0.0], [0.0, -0.2, 0.0], True),
    ([0.0, 0.0, 0.0], [0.0, 0.0, -0.2], True),
])
def test_clamp_to_shell_moves_radially(p, expect, clamped):
    out, moved = clamp_to_shell(np.array(p, float), np.zeros(3), 0.2, 1.0)
    np.testing.assert_allclose(out, expect, atol=1e-12)
    assert moved is clamped


def test_reach_shell_matches_the_arm_geometry(robot):
    """Radii from the law of cosines on the MJCF's segment offsets (upper arm 0.344 m, elbow
    to palm 0.27 + 0.08 m, elbow flexion up to 2.4 rad), minus the 1 cm margin."""
    m, q = robot
    T = np.eye(4)
    T[2, 3] = 0.981
    a, b = 0.344, 0.27 + 0.08
    theta_max = m.jnt_range[m.joint("R_EB").id][1]
    shell = reach_shell(m, q, "R_palm", T)
    assert shell.r_max == pytest.approx(a + b - 0.01, abs=1e-6)
    r_min = math.sqrt(a * a + b * b + 2 * a * b * math.cos(theta_max))
    assert shell.r_min == pytest.approx(r_min + 0.01, abs=2e-3)  # 49-point sweep
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(shell.center, d.body("R_upper_arm").xpos - T[:3, 3], atol=1e-12)
    elbow = reach_shell(m, q, "L_elbow", T)
    assert elbow.r_min == pytest.approx(a) and elbow.r_max == pytest.approx(a)
