"""JointTrajectory: closed forms, MuJoCo's own finite differences of configurations."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.motion import JointTrajectory, MotionContext, make_motion, quat
from humimic.motion.avatar import (
    BALL_JOINTS,
    DOF_SLICES,
    QPOS_SLICES,
    load_avatar_model,
    zero_qpos,
)
from humimic.motion.config import WaveMotion

RATE = 240.0


def _closed_form_samples(t):
    """Spine turning at a constant local rate about a fixed axis, elbow a sinusoid,
    root_x a cubic."""
    q = zero_qpos(len(t))
    w = np.array([0.3, -0.5, 1.2])
    q[:, QPOS_SLICES["spine"]] = quat.from_rotvec(np.outer(t, w))
    q[:, QPOS_SLICES["r_elbow"].start] = 0.8 + 0.5 * np.sin(2 * np.pi * 0.7 * t)
    q[:, 0] = 0.1 * t**3
    return q, w


def test_closed_form_derivatives():
    t = np.arange(0, 3.0, 1 / RATE)
    q, w = _closed_form_samples(t)
    traj = JointTrajectory(t, q)
    te = np.linspace(0.2, 2.8, 97)
    qp, qv, qa = traj.evaluate(te)
    # measured 2026-11-29 (the bounds in brackets): 1.7e-13 [1e-7], 1.4e-10 [1e-8], 2.4e-13
    # [1e-8], 1.5e-9 [1e-6], 2.0e-13 [1e-9], 1.2e-10 [1e-7]
    np.testing.assert_allclose(qv[:, DOF_SLICES["spine"]], np.broadcast_to(w, (97, 3)),
                               atol=1e-11)
    np.testing.assert_allclose(qa[:, DOF_SLICES["spine"]], 0.0, atol=4e-10)
    om = 2 * np.pi * 0.7
    np.testing.assert_allclose(qv[:, DOF_SLICES["r_elbow"].start],
                               0.5 * om * np.cos(om * te), atol=1e-11)
    np.testing.assert_allclose(qa[:, DOF_SLICES["r_elbow"].start],
                               -0.5 * om**2 * np.sin(om * te), atol=5e-9)
    np.testing.assert_allclose(qv[:, 0], 0.3 * te**2, atol=1e-11)
    np.testing.assert_allclose(qa[:, 0], 0.6 * te, atol=4e-10)
    # positions: scalars exact at the samples; quaternions unit and on the true rotation
    elbow = QPOS_SLICES["r_elbow"].start
    np.testing.assert_allclose(traj.qpos(t)[:, elbow], q[:, elbow], atol=1e-12)
    spine = qp[:, QPOS_SLICES["spine"]]
    np.testing.assert_allclose(np.linalg.norm(spine, axis=1), 1.0, atol=1e-12)
    exact = quat.from_rotvec(np.outer(te, w))
    np.testing.assert_allclose(np.abs(np.sum(spine * exact, axis=1)), 1.0, atol=1e-10)


def test_hemisphere_flips_in_samples_are_harmless():
    t = np.arange(0, 2.0, 1 / RATE)
    q, _ = _closed_form_samples(t)
    flipped = q.copy()
    for j in BALL_JOINTS:
        s = QPOS_SLICES[j]
        flipped[::3, s] *= -1.0
    te = np.linspace(0.1, 1.9, 50)
    for a, b in zip(JointTrajectory(t, q).evaluate(te), JointTrajectory(t, flipped).evaluate(te),
                    strict=True):
        np.testing.assert_allclose(np.abs(a), np.abs(b), atol=1e-12)


@pytest.fixture(scope="module")
def wave_trajectory():
    ctx = MotionContext.facing_robot(duration=4.0)
    motion = make_motion(WaveMotion(period=1.5), ctx)
    return motion, JointTrajectory.from_motion(motion, 4.0)


def test_velocity_and_acceleration_match_mujoco_finite_differences(wave_trajectory):
    """qvel vs mj_differentiatePos of positions at t +- h; qacc vs central differences of qvel."""
    _, traj = wave_trajectory
    m = load_avatar_model()
    h = 1e-4
    t = np.linspace(0.3, 3.7, 41)
    q_minus, q_plus = traj.qpos(t - h), traj.qpos(t + h)
    _, qvel, qacc = traj.evaluate(t)
    fd = np.empty_like(qvel)
    for i in range(len(t)):
        mujoco.mj_differentiatePos(m, fd[i], 2 * h, q_minus[i], q_plus[i])
    scale = np.max(np.abs(qvel))
    np.testing.assert_allclose(fd, qvel, atol=1e-6 * scale)
    fd_acc = (traj.qvel(t + h) - traj.qvel(t - h)) / (2 * h)
    np.testing.assert_allclose(fd_acc, qacc, atol=1e-5 * np.max(np.abs(qacc)))


def test_fit_is_faithful_between_samples(wave_trajectory):
    """Between the 240 Hz samples the spline stays on the motion (joint space, < 1e-5 rad)."""
    motion, traj = wave_trajectory
    t = (np.arange(100) + 0.5) / RATE + 0.5
    a, b = motion.sample(t), traj.qpos(t)
    for j in BALL_JOINTS:
        s = QPOS_SLICES[j]
        assert np.max(quat.angle(quat.mul(quat.conj(a[:, s]), b[:, s]))) < 1e-5
    assert np.max(np.abs(a[:, 0:3] - b[:, 0:3])) < 1e-6


def test_outside_range_holds_at_rest(wave_trajectory):
    _, traj = wave_trajectory
    qp, qv, qa = traj.evaluate(np.array([-1.0, traj.t1 + 1.0]))
    np.testing.assert_allclose(qp[0], traj.qpos(traj.t0)[0])
    np.testing.assert_allclose(qp[1], traj.qpos(traj.t1)[0])
    assert not qv.any() and not qa.any()
