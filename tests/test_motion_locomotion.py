"""The walking and jumping person: waypoints reached at rest, the gait's bob at the step
frequency, headings, palm keyframes in the walking body's frame, and a jump whose flight is
ballistic (the worn accelerometers read ~0) with the feet on the floor while crouching."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.motion import JointTrajectory, MotionContext, compute_ground_truth, make_motion
from humimic.motion.config import JumpMotion, WalkMotion
from humimic.motion.gait import GRAVITY, jump_duration, jump_profile, quintic_hermite
from humimic.world.scene import SceneOptions, build_scene

RATE = 840.0


@pytest.fixture(scope="module")
def scene():
    return build_scene(SceneOptions(room="sugiyama", show_wiimote=True))


def _truth(scene, cfg, duration):
    ctx = MotionContext.from_scene(scene, duration, np.random.default_rng(0))
    motion = make_motion(cfg, ctx)
    traj = JointTrajectory.from_motion(motion, duration)
    t = np.arange(int(duration * RATE)) / RATE
    return motion, t, compute_ground_truth(scene, traj, t)


@pytest.fixture(scope="module")
def walk(scene):
    cfg = WalkMotion(waypoints=[
        {"t": 0.0, "at": [0.0, -2.5]}, {"t": 1.0, "at": [0.0, -2.5]},
        {"t": 5.0, "at": [0.0, 0.0]}, {"t": 6.0, "at": [0.0, 0.0], "heading_deg": 30},
        {"t": 7.0, "at": [0.0, 0.0]}],
        right_hand=[{"t": 0.0, "p": [0.3, -0.2, 1.2]}, {"t": 4.0, "p": [0.5, -0.2, 1.4]}])
    return (cfg, *_truth(scene, cfg, 7.5))


def test_walk_stands_on_its_waypoints_facing_their_heading(walk, scene):
    cfg, motion, t, gt = walk
    p_W = gt.position("pelvis", "W")
    for w, heading in ((cfg.waypoints[1], 0.0), (cfg.waypoints[2], 0.0),
                       (cfg.waypoints[3], 30.0)):
        k = int(round(w.t * RATE))
        np.testing.assert_allclose(p_W[k, [0, 2]], w.at, atol=1e-6)  # at rest: no sway
        z_I = gt.rotation("headcam", "W")[k][:, 2]  # the optical axis
        assert np.degrees(np.arctan2(z_I[0], z_I[2])) == pytest.approx(heading, abs=1e-6)
        assert np.linalg.norm(gt.velocity("headcam", "W")[k]) < 1e-6


def test_walking_bobs_the_head_at_the_step_frequency(walk):
    cfg, _, t, gt = walk
    sel = (t > 2.0) & (t < 4.0)  # mid-walk, near full speed
    y = gt.position("headcam", "W")[sel, 1]
    y = y - np.polyval(np.polyfit(t[sel], y, 2), t[sel])
    spectrum = np.abs(np.fft.rfft(y * np.hanning(len(y)), n=8 * len(y)))
    freqs = np.fft.rfftfreq(8 * len(y), 1 / RATE)
    # within one bin of the zero-padded spectrum (0.0625 Hz): measured 2.0012 Hz (was 0.15)
    assert freqs[np.argmax(spectrum)] == pytest.approx(cfg.step_frequency, abs=0.07)
    # 4 cm peak to peak at full activity, a little less at ~0.8 m/s
    assert 0.02 < np.ptp(y) < 0.045
    # vertical acceleration of a walking head: a few m/s^2
    assert 1.0 < np.abs(gt.acceleration("headcam", "W")[sel, 1]).max() < 6.0


def test_palm_keyframes_are_in_the_walking_body_frame(walk):
    _, motion, t, gt = walk
    k = int(4.0 * RATE)
    xy, psi, _ = motion.root(t[[k]])
    # body frame: the avatar frame moved to the root (with its bob and sway) and turned
    q = gt.qpos[k]
    origin = q[0:3]
    R = np.array([[np.cos(psi[0]), -np.sin(psi[0]), 0], [np.sin(psi[0]), np.cos(psi[0]), 0],
                  [0, 0, 1]])
    p_avatar = origin + R @ np.array([0.5, -0.2, 1.4])
    T_world_avatar = gt.T_world_frame("W") @ np.linalg.inv(
        MotionContext.from_scene(build_scene(SceneOptions(room="sugiyama")), 1.0,
                                 np.random.default_rng(0)).T_avatar_W)
    p_world = T_world_avatar[:3, :3] @ p_avatar + T_world_avatar[:3, 3]
    np.testing.assert_allclose(gt.p_world("right_hand")[k], p_world, atol=1e-6)


def test_the_wii_remote_points_along_the_forearm_buttons_up(walk):
    """Arm raised forward: the remote's z (pointing end) is horizontal-ish and forward, its y
    (button face) up, as the paper's Fig. 3 asks at the start of the arm estimation."""
    _, _, t, gt = walk
    k = int(4.0 * RATE)
    R = gt.rotation("wiimote", "W")[k]
    assert R[:, 2] @ np.array([0.0, 0.0, 1.0]) > 0.8  # points towards the screen
    assert R[:, 1] @ np.array([0.0, 1.0, 0.0]) > 0.8  # buttons up


def test_jump_profile_is_c2_and_ballistic():
    t = np.arange(0.0, 3.0, 1e-4)
    z = jump_profile(t, 0.5, 0.2, 0.15)
    v, a = np.gradient(z, t), np.gradient(np.gradient(z, t), t)
    assert z.max() == pytest.approx(0.2, abs=1e-8)  # measured 3.7e-9 (was 1e-4)
    assert z.min() >= -0.15 - 0.02  # the landing dips at most 2 cm below the crouch
    # no step in acceleration between the phases: the steepest change per 0.1 ms step is the
    # push's jerk (~1000 m/s^3: 0.1 m/s^2), a discontinuity of even 1 m/s^2 would show
    assert np.abs(np.diff(a)).max() < 0.3
    flight = z > 0.01
    np.testing.assert_allclose(a[flight][2:-2], -GRAVITY, atol=3e-8)  # measured 7.6e-9
    assert 2.0 * GRAVITY < a.max() < 3.0 * GRAVITY  # the push
    take_off = np.argmax(z > 0.0)  # leaves standing height at the take-off speed
    # measured 4.3e-7 relative and 1.45e-4 s (the flight time to 3 decimals; 2026-11-29; the
    # bounds were 2e-3 and 1e-3)
    assert v[take_off] == pytest.approx(np.sqrt(2 * GRAVITY * 0.2), rel=1.5e-6)
    assert jump_duration(0.2) == pytest.approx(0.45 + 0.22 + 0.404 + 0.25 + 0.6, abs=4e-4)


def test_quintic_hermite_meets_its_boundary_values():
    p, v, a = quintic_hermite((1.0, -2.0, 3.0), (0.5, 4.0, -9.81), 0.3, np.array([0.0, 0.3]))
    np.testing.assert_allclose([p[0], v[0], a[0]], [1.0, -2.0, 3.0], atol=1e-12)
    np.testing.assert_allclose([p[1], v[1], a[1]], [0.5, 4.0, -9.81], atol=1e-9)


def test_jump_in_flight_the_worn_accelerometers_read_free_fall(scene):
    cfg = JumpMotion(start=0.5, height=0.2, crouch=0.15)
    motion, t, gt = _truth(scene, cfg, 3.0)
    z = motion.height(t)
    flight = z > 0.02
    assert flight.sum() > 200
    f = gt.specific_force("head_imu")[flight]
    # 9.81 m/s^2 standing; measured 0.042 m/s^2 in flight, both sensors (2026-11-29)
    assert np.linalg.norm(f, axis=1).max() < 0.12
    f_wii = gt.specific_force("wiimote")[flight]
    assert np.linalg.norm(f_wii, axis=1).max() < 0.12
    # the head rises by the jump's height
    y = gt.position("headcam", "W")[:, 1]
    assert y.max() - y[0] == pytest.approx(0.2, abs=5e-6)  # measured 1.2e-6 short (was 5 mm)


def test_jump_crouch_keeps_the_soles_on_the_floor(scene):
    cfg = JumpMotion(start=0.2, height=0.2, crouch=0.15)
    ctx = MotionContext.from_scene(scene, 2.0, np.random.default_rng(0))
    motion = make_motion(cfg, ctx)
    t = np.array([0.0, 0.45, 0.6])  # standing, deepest crouch, push
    q = motion.sample(t)
    m, d = scene.model, mujoco.MjData(scene.model)
    for qq in q:
        d.qpos[scene.human_qpos] = qq
        mujoco.mj_kinematics(m, d)
        for foot in ("human/r_foot", "human/l_foot"):
            g = m.geom(foot)
            R = d.geom_xmat[g.id].reshape(3, 3)
            corners = d.geom_xpos[g.id] + (np.array([[sx, sy, -g.size[2]]
                                                     for sx in (-1, 1) for sy in (-1, 1)])
                                           * [g.size[0], g.size[1], 1]) @ R.T
            # on the floor to rounding: measured <= 6e-17 m (the bound was 12 mm)
            assert np.abs(corners[:, 2]).max() < 1e-9, corners[:, 2]
