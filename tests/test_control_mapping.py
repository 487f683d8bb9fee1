"""Relative-motion mapping and workspace clamping (Ude & Atkeson, relative motion)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from humimic.control.ik import build_robot_model
from humimic.control.mapping import (
    ReachShell,
    ScaleFit,
    arm_length,
    auto_scale,
    clamp_to_shell,
    map_displacement,
    mapping_matrix,
    reach_along_ray,
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


# ---- scale: auto from arm lengths, fitted to the reach ------------------------------------------
def _reach_by_sampling(a, u, lam, c, r_min, r_max):
    """The largest l <= lam with a + l u in the shell, by dense sampling down from lam and
    bisection (independent of the closed form)."""
    def inside(x):
        r = np.linalg.norm(a + np.multiply.outer(x, u) - c, axis=-1)
        return (r_min <= r) & (r <= r_max)
    ls = np.linspace(lam, 0.0, 40001)
    first = int(np.argmax(inside(ls)))  # the first feasible point coming back
    if first == 0:
        return lam
    lo, out = ls[first], ls[first - 1]
    for _ in range(60):
        mid = 0.5 * (lo + out)
        lo, out = (mid, out) if inside(mid) else (lo, mid)
    return lo


def test_reach_along_ray_matches_sampling():
    rng = np.random.default_rng(3)
    c, r_min, r_max = np.array([0.0, -0.19, 0.53]), 0.2, 0.68
    for _ in range(60):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        w = rng.normal(size=3)
        a = c + rng.uniform(r_min + 0.01, r_max - 0.01) * w / np.linalg.norm(w)
        lam = rng.uniform(0.0, 1.5)
        assert reach_along_ray(a, u, lam, c, r_min, r_max) == pytest.approx(
            _reach_by_sampling(a, u, lam, c, r_min, r_max), abs=1e-9)
    # through the inner sphere and out again: the end is in the shell, nothing to give up
    a = c + np.array([0.4, 0.0, 0.0])
    assert reach_along_ray(a, np.array([-1.0, 0, 0]), 0.7, c, r_min, r_max) == 0.7
    assert reach_along_ray(a, np.array([-1.0, 0, 0]), 0.4, c, r_min, r_max) == pytest.approx(0.2)


def test_arm_length_and_auto_scale(robot):
    m, _ = robot
    a, b = 0.344, 0.27 + 0.08  # the MJCF's segment offsets
    assert arm_length(m, "R_palm") == pytest.approx(a + b, abs=1e-9)
    assert arm_length(m, "L_elbow") == pytest.approx(a, abs=1e-9)
    assert auto_scale(a + b, 0.3, 0.3, "R_palm") == pytest.approx((a + b) / 0.6)
    assert auto_scale(a, 0.3, 0.3, "R_elbow") == pytest.approx(a / 0.3)


def test_scale_fit_shrinks_to_keep_the_motion_inside_and_never_grows():
    shell = ReachShell(np.zeros(3), 0.1, 0.7)
    anchor = np.array([0.4, 0.0, 0.0])
    fit = ScaleFit(1.0, shell, anchor, margin=0.0, time_constant=0.0, dt=1 / 420)
    assert fit.update(np.array([0.2, 0.0, 0.0])) == 1.0       # 0.6 < 0.7: fits
    assert fit.update(np.array([0.6, 0.0, 0.0])) == pytest.approx(0.5)  # 0.4 + 0.5 * 0.6
    assert fit.update(np.array([0.1, 0.0, 0.0])) == pytest.approx(0.5)  # never grows back
    # inward, ending inside the inner sphere: from 0.4 to 0.1 is 0.3 of room
    assert fit.update(np.array([-0.8, 0.0, 0.0])) == pytest.approx(0.3 / 0.8)
    # through the inner sphere and out on the other side: in the shell, nothing to shrink
    assert fit.update(np.array([-1.8, 0.0, 0.0])) == pytest.approx(0.3 / 0.8)
    slow = ScaleFit(1.0, shell, anchor, margin=0.05, time_constant=0.1, dt=0.01)
    s = [slow.update(np.array([0.6, 0.0, 0.0])) for _ in range(100)]
    bound = (0.65 - 0.4) / 0.6
    assert s[0] == pytest.approx(1.0 - 0.1 * (1.0 - bound))  # first-order decay, gain dt/tau
    assert s[-1] == pytest.approx(bound, rel=1e-3) and np.all(np.diff(s) <= 0)
