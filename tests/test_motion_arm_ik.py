"""Analytic arm IK checked with MuJoCo's forward kinematics of models/avatar.xml."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from _kinematics import site_positions

from humimic.motion import quat
from humimic.motion.arm_ik import reach_limits, solve_arm
from humimic.motion.avatar import (
    QPOS_SLICES,
    AvatarGeometry,
    chest_pose,
    load_avatar_model,
    shoulder_position,
    zero_qpos,
)


@pytest.fixture(scope="module")
def avatar():
    m = load_avatar_model()
    return m, mujoco.MjData(m), AvatarGeometry.from_model(m)


def _random_torso(rng, n):
    q = zero_qpos(n)
    q[:, 0:3] = rng.normal(0.0, 0.1, (n, 3))
    q[:, QPOS_SLICES["root_rot"]] = quat.from_rotvec(rng.normal(0.0, 0.3, (n, 3)))
    q[:, QPOS_SLICES["spine"]] = quat.from_rotvec(rng.normal(0.0, 0.2, (n, 3)))
    return q


def _apply(q, side, res):
    q[:, QPOS_SLICES[f"{side}_shoulder"]] = res.q_shoulder
    q[:, QPOS_SLICES[f"{side}_elbow"].start] = res.elbow
    q[:, QPOS_SLICES[f"{side}_wrist"]] = res.q_wrist


@pytest.mark.parametrize("side", ["r", "l"])
def test_reachable_targets_are_reached(avatar, side):
    m, d, g = avatar
    rng = np.random.default_rng(1)
    n = 150
    q = _random_torso(rng, n)
    d_min, d_max = reach_limits(g, side)
    p_sh = shoulder_position(q, g, side)
    direction = quat.normalize(rng.normal(size=(n, 3)))
    target = p_sh + direction * rng.uniform(d_min + 1e-3, d_max - 1e-3, n)[:, None]
    R_c, p_c = chest_pose(q, g)
    res = solve_arm(side, target, R_c, p_c, g)
    assert res.reachable.all() and np.all(res.clamp_distance < 1e-12)
    _apply(q, side, res)
    palm = site_positions(m, q, [f"{side}_hand"])[f"{side}_hand"]
    assert np.max(np.linalg.norm(palm - target, axis=1)) < 1e-9  # measured 7e-16 m (was 1 mm)
    # joints inside the model's ranges
    lo, hi = g.ranges[f"{side}_elbow"]
    assert np.all((res.elbow >= lo) & (res.elbow <= hi + 1e-9))
    assert np.all(quat.angle(res.q_wrist) <= g.ranges[f"{side}_wrist"][1])


def test_unreachable_targets_are_clamped_and_reported(avatar):
    m, d, g = avatar
    rng = np.random.default_rng(2)
    n = 40
    q = zero_qpos(n)
    d_min, d_max = reach_limits(g, "r")
    p_sh = shoulder_position(q, g, "r")
    direction = quat.normalize(rng.normal(size=(n, 3)))
    dist = np.where(np.arange(n) % 2 == 0, rng.uniform(1.1, 2.0, n) * d_max,
                    rng.uniform(0.0, 0.9, n) * d_min)
    target = p_sh + direction * dist[:, None]
    R_c, p_c = chest_pose(q, g)
    res = solve_arm("r", target, R_c, p_c, g)
    assert not res.reachable.any()
    _apply(q, "r", res)
    palm = site_positions(m, q, ["r_hand"])["r_hand"]
    np.testing.assert_allclose(palm, res.p_reached, atol=1e-6)
    shell = np.where(dist > d_max, d_max, d_min)
    np.testing.assert_allclose(np.linalg.norm(palm - p_sh, axis=1), shell, atol=1e-6)
    # clamped along the shoulder-target line, by the reported distance
    np.testing.assert_allclose(quat.normalize(palm - p_sh), direction, atol=1e-6)
    np.testing.assert_allclose(res.clamp_distance, np.abs(dist - shell), atol=1e-9)


def test_waving_hand_faces_robot_with_elbow_low_and_out(avatar):
    """A palm beside the head: the palm normal points to +x (the robot), the elbow hangs
    below the shoulder-palm line and outside it."""
    m, d, g = avatar
    n = 30
    q = zero_qpos(n)
    y = np.linspace(-0.70, -0.20, n)
    target = np.stack([np.full(n, 0.10), y, 1.70 - 0.1 * ((y + 0.45) / 0.25) ** 2], axis=1)
    R_c, p_c = chest_pose(q, g)
    res = solve_arm("r", target, R_c, p_c, g, palm_dir_avatar=np.array([1.0, 0.0, 0.0]))
    _apply(q, "r", res)
    sites = site_positions(m, q, ["r_shoulder", "r_elbow", "r_hand"])
    palm_normal = []
    for qq in q:
        d.qpos[:] = qq
        mujoco.mj_kinematics(m, d)
        palm_normal.append(d.body("r_hand").xmat.reshape(3, 3)[:, 1])  # right palm: hand +y
    palm_normal = np.array(palm_normal)
    assert np.min(palm_normal[:, 0]) > np.cos(np.radians(25))
    sh, el, pa = sites["r_shoulder"], sites["r_elbow"], sites["r_hand"]
    w = quat.normalize(pa - sh)
    off = (el - sh) - np.sum((el - sh) * w, axis=1, keepdims=True) * w
    assert np.all(off[:, 2] < -0.05)  # below the line
    assert np.all(off[:, 1] < -0.03)  # outside (the right arm's outside is -y)
