"""Ground truth vs independent computations: finite differences of mj_kinematics positions,
gravity-free accelerations vs the accelerometer, frame changes, and speed."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.motion import (
    JointTrajectory,
    MotionContext,
    compute_ground_truth,
    make_motion,
)
from humimic.motion.config import HeadSweepMotion, WaveMotion
from humimic.world.names import HUMAN_TARGETS
from humimic.world.scene import build_scene


@pytest.fixture(scope="module")
def scene():
    return build_scene()


@pytest.fixture(scope="module")
def motion_gt(scene):
    """A wave of the right hand during a head sweep would need two motions; a head sweep moves
    the whole body (root slides and balls), a wave the arm: test both."""
    ctx = MotionContext.from_scene(scene, 3.0, np.random.default_rng(0))
    out = {}
    for name, cfg in (("wave", WaveMotion(period=1.2)), ("sweep", HeadSweepMotion(period=1.5))):
        traj = JointTrajectory.from_motion(make_motion(cfg, ctx), 3.0)
        t = np.linspace(0.2, 2.8, 60)
        out[name] = (traj, t, compute_ground_truth(scene, traj, t))
    return out


def _positions(scene, traj, t):
    """World site positions by mj_kinematics only, and the IMU site rotations."""
    m = scene.model
    d = mujoco.MjData(m)
    sites = [scene.human_site(k) for k in HUMAN_TARGETS]
    q = traj.qpos(t)
    p, R = [], []
    for qq in q:
        d.qpos[scene.human_qpos] = qq
        mujoco.mj_kinematics(m, d)
        p.append(d.site_xpos[sites].copy())
        R.append(d.site_xmat[[scene.human_site("head_imu"), scene.human_site("wiimote")]]
                 .reshape(2, 3, 3).copy())
    return np.array(p), np.array(R)


@pytest.mark.parametrize("name", ["wave", "sweep"])
def test_velocity_and_acceleration_match_finite_differences(scene, motion_gt, name):
    traj, t, gt = motion_gt[name]
    h = 1e-4
    p_m, _ = _positions(scene, traj, t - h)
    p_0, _ = _positions(scene, traj, t)
    p_p, _ = _positions(scene, traj, t + h)
    np.testing.assert_allclose(gt.pos, p_0, atol=1e-12)
    v_fd = (p_p - p_m) / (2 * h)
    a_fd = (p_p - 2 * p_0 + p_m) / h**2
    # truncation (h^2/6 |d3p|, h^2/12 |d4p|) and rounding (4 eps |p| / h^2) stay far below
    # these tolerances for these motions
    np.testing.assert_allclose(gt.vel, v_fd, atol=2e-6)
    np.testing.assert_allclose(gt.acc, a_fd, atol=1e-4)
    assert np.max(np.abs(gt.acc)) > 1.0  # the motion is not trivially still


@pytest.mark.parametrize("name", ["wave", "sweep"])
def test_true_imu_readings(scene, motion_gt, name):
    traj, t, gt = motion_gt[name]
    g = scene.model.opt.gravity
    h = 1e-4
    _, R_m = _positions(scene, traj, t - h)
    _, R_p = _positions(scene, traj, t + h)
    for target, acc, gyro in (("head_imu", "head_acc", "head_gyro"),
                              ("wiimote", "wiimote_acc", "wiimote_gyro")):
        R = gt.R_world(target)
        f_expected = np.einsum("nji,nj->ni", R, gt.a_world(target) - g)
        np.testing.assert_allclose(gt.sensor(acc), f_expected, atol=1e-6)
        k = ("head_imu", "wiimote").index(target)
        dR = (R_p[:, k] - R_m[:, k]) / (2 * h)
        W = np.swapaxes(R, 1, 2) @ dR  # R^T dR/dt = [w]x in the site frame
        w_fd = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        np.testing.assert_allclose(gt.sensor(gyro), w_fd, atol=1e-5)
        acc2, gyro2 = gt.inertial(target)
        assert acc2 is gt.sensor(acc) and gyro2 is gt.sensor(gyro)


def test_base_frame_and_indexing(scene, motion_gt):
    _, t, gt = motion_gt["wave"]
    T = scene.T_world_base
    p_world = gt.p_world("right_hand")
    np.testing.assert_allclose(gt.p_base("right_hand"),
                               (p_world - T[:3, 3]) @ T[:3, :3], atol=1e-12)
    hom = np.c_[gt.p_base("head"), np.ones(len(t))] @ T.T
    np.testing.assert_allclose(hom[:, :3], gt.p_world("head"), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(gt.v_base("right_hand"), axis=1),
                               np.linalg.norm(gt.v_world("right_hand"), axis=1), atol=1e-12)
    # the robot faces the person: the person's right hand waving along avatar y moves along
    # the robot's y too (avatar +y = world -x ... = robot -y), so |v_y| dominates in the base
    v = gt.v_base("right_hand")
    assert np.mean(np.abs(v[:, 1])) > 2 * np.mean(np.abs(v[:, 0]))
    assert gt.index_of(t[7] + 1e-6) == 7
    np.testing.assert_array_equal(gt.index_of(t[[3, 5]]), [3, 5])
    with pytest.raises(ValueError):
        gt.index_of(t[-1] + 1.0)
    assert gt.qpos.shape == (len(t), 51) and gt.qvel.shape == (len(t), 40)


def test_chunks_agree_and_scene_data_untouched(scene):
    ctx = MotionContext.from_scene(scene, 10.0, np.random.default_rng(0))
    traj = JointTrajectory.from_motion(make_motion(WaveMotion(), ctx), 10.0)
    qpos_before = scene.data.qpos.copy()
    t = np.arange(8400) / 840.0
    gt = compute_ground_truth(scene, traj, t)
    np.testing.assert_array_equal(scene.data.qpos, qpos_before)
    assert gt.pos.shape == (8400, len(HUMAN_TARGETS), 3)
    # samples past the first chunk agree with a separate computation at those times
    few = compute_ground_truth(scene, traj, t[[5000, 8399]])
    np.testing.assert_array_equal(few.acc, gt.acc[[5000, 8399]])
    np.testing.assert_array_equal(few.sensor("wiimote_acc"), gt.sensor("wiimote_acc")[[5000, 8399]])
    # the speed goal (>= 20,000 samples/s) is benchmarks/bench_world.py's, not a timed test
