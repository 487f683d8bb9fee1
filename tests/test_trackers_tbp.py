"""TBP (Menezes secs. 6.2-6.3): the auxiliary filter with its own first stage against the
Kalman filter; the constant-velocity model, the collision prior and the torso placed from
the head against closed forms; the likelihood peaks at the avatar's true arm angles in a
rendered frame."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from test_particles import DYN, KF_LOGLIK, KF_MEANS, PRIOR, ZS, _loglik

from humimic.bodymodel.avatar import truth_state
from humimic.bodymodel.dimensions import avatar_body
from humimic.estimation.particles import apf_step, initialize
from humimic.paths import SCENARIOS_DIR
from humimic.perception.trackers.tbp.likelihood import (
    arm_view,
    collision,
    full_log_likelihood,
    patch_histograms_all,
    project_arms,
)
from humimic.perception.trackers.tbp.stage import torso_from_head
from humimic.perception.trackers.tbp.tracker import ARM_NAMES, cv_dynamics
from humimic.rngs import Rngs
from humimic.scenario import load_scenario


def test_apf_with_a_cheaper_first_stage_matches_the_kalman_filter():
    """First stage: the likelihood tempered to a quarter (a cheaper, flatter cue); the second
    stage divides it out, so the filter stays consistent."""
    errs, lls = [], []
    for r in range(4):
        rng = np.random.default_rng(r)
        x, lw = initialize(PRIOR, 800, rng)
        means, total = [], 0.0
        for z in ZS:
            ll = _loglik(z)
            s = apf_step(x, lw, DYN, ll, rng, first_stage=lambda x, ll=ll: 0.25 * ll(x))
            x, lw = s.particles, s.log_weights
            means.append(s.mean)
            total += s.log_evidence
        errs.append(np.array(means)[:, 0] - KF_MEANS[:, 0])
        lls.append(total - KF_LOGLIK)
    # measured 0.0069 (posterior sd 0.07) and 0.17 nats on 2026-11-29 (the second bound was 1.0)
    assert np.sqrt(np.mean(np.square(errs))) < 0.01
    assert np.sqrt(np.mean(np.square(lls))) < 0.5


def test_constant_velocity_model():
    dyn = cv_dynamics(8, 0.05)
    q1, q0 = np.arange(8.0), np.arange(8.0) - 0.1
    np.testing.assert_allclose(dyn.mean(np.r_[q1, q0][None])[0], np.r_[q1 + 0.1, q1])
    damped = cv_dynamics(8, 0.05, keep=0.85)          # the default: q1 + 0.85 (q1 - q0)
    np.testing.assert_allclose(damped.mean(np.r_[q1, q0][None])[0], np.r_[q1 + 0.085, q1])


def test_collision_and_torso_from_head():
    body = avatar_body(torso="cylinder").with_free(ARM_NAMES)
    torso = np.array([1.5, 0.1, 0.9, np.pi, 0.0, 0.0])
    rest = np.radians([5, 5, 0, 10] * 2)
    across = np.radians([60, -40, 80, 120, 5, 5, 0, 10])       # right hand into the chest
    f = collision(body.forward(np.stack([rest, across]), fixed=torso), body)
    np.testing.assert_array_equal(f, [0.0, 1.0])
    head = body.part("head")
    offset = body.skeleton.neck + head.p_seg_part
    p_head = np.array([1.6, -0.2, 1.55])
    t = torso_from_head(p_head, offset)
    pose = body.forward(rest[None], fixed=t)
    R, p = pose.segment("head")
    np.testing.assert_allclose(p[0] + R[0] @ head.p_seg_part, p_head, atol=1e-12)
    # facing the robot: the torso's forward axis points at the base origin (horizontally)
    fwd = pose.segment("torso")[0][0][:, 0]
    np.testing.assert_allclose(fwd[:2] / np.linalg.norm(fwd[:2]),
                               -p_head[:2] / np.linalg.norm(p_head[:2]), atol=1e-12)


@pytest.fixture(scope="module")
def rendered_pointing():
    """fig12's pointing arm at t = 2 s (right arm raised sideways), the left eye's frame and
    the frame before it (optical flow), the tracker's weights with truth-pose references."""
    from humimic.perception.trackers.tbp.build import tbp_stage
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "fig12_tbp_pointing.yaml", ["trackers.tbp.torso=truth"],
                       duration=2.1)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    stage = tbp_stage("tbp", sc.trackers["tbp"], sc, world, rngs, None)
    trk, frames = stage.tracker, []
    for t in (2.0 - 1 / 30, 2.0):
        tick = world.gt.index_of(t)
        world.apply_human(tick)
        mujoco.mj_forward(world.scene.model, world.scene.data)
        frames.append(world.eye_rig.capture(t)[stage.camera])
    world.eye_rig.close()
    view = arm_view(frames[1], trk.flow(frames[0].image, frames[1].image), trk.lut, 32,
                    trk.cfg.edges == "colour")
    truth = truth_state(world, tick, "base")
    trk._first_frame(view, truth[:6])
    refs = patch_histograms_all(project_arms(trk.body, truth[None, 6:], truth[:6], view, 4),
                                view.qimage)[0]
    return trk, view, truth, refs


#: DOF index, margin (nats) of the true pose over +-20 deg on it; measured (the smaller of
#: the two signs) with the tracker's defaults (colour-gradient edges): R_SFE 0.44 (+20 deg
#: moves the raised arm towards the camera: monocular depth), R_SAA 27, R_HR 3.3, R_EB 12,
#: L_SFE 4.4, L_SAA 9.2, L_HR 0.34 (the hanging arm's twist is unobservable: the stabiliser
#: alone), L_EB 2.4. (Grey edges: R_HR 0.99, R_EB 8.9, L_SFE 13, L_SAA 12.)
MARGINS = [(0, 0.15), (1, 9.0), (2, 1.1), (3, 4.0), (4, 1.5), (5, 3.0), (6, 0.1), (7, 0.8)]


@pytest.mark.parametrize(("dof", "margin"), MARGINS)
def test_likelihood_peaks_at_the_true_arm_angles(rendered_pointing, dof, margin):
    trk, view, truth, refs = rendered_pointing
    q = truth[6:]
    xs = np.stack([q, q, q])
    xs[1, dof] -= np.radians(20)
    xs[2, dof] += np.radians(20)
    proj = project_arms(trk.body, xs, truth[:6], view, trk.cfg.n_points)
    ll = full_log_likelihood(proj, view, xs, trk.body, trk.weights, refs)
    assert min(ll[0] - ll[1], ll[0] - ll[2]) > margin, (ll[0] - ll[1], ll[0] - ll[2])


def test_kalman_filter_overshoots_an_end_stop_the_particle_filter_cannot():
    """An elbow flexing at 3 rad/s that stops dead at its 150 deg limit, measured with 1 deg
    of noise: the random-jerk filter's estimate goes further past the limit than the noisy
    measurements themselves (measured 2.8 against 1.8 deg); a clamped estimate never leaves
    the limits."""
    from humimic.perception.trackers.tbp.kalman import beyond_limits, kalman_end_stops

    t = np.arange(0, 2.0, 1 / 30)
    lo, hi = np.zeros(3), np.full(3, np.radians(150.0))
    eb = np.minimum(0.3 + 3.0 * t, hi[0])
    truth = np.column_stack([np.full_like(t, 0.5), np.full_like(t, 0.5), eb])
    est, z = kalman_end_stops(t, truth, lo, hi, np.radians(1.0), 30.0,
                              np.random.default_rng(0))
    over = beyond_limits(est, lo, hi).max()
    assert over > 1.3 * beyond_limits(z, lo, hi).max(), over
    np.testing.assert_array_equal(beyond_limits(np.clip(est, lo, hi), lo, hi), 0.0)
    np.testing.assert_allclose(beyond_limits(np.array([[-0.1, 0.2, 3.0]]), lo, hi),
                               [[0.1, 0.0, 3.0 - hi[2]]])


def test_tbp_follows_fig13s_arms_in_clutter():
    """The first 1.5 s of fig13 (both arms abducting in front of the cluttered cupboard; torso
    from the truth so that only the tracker is scored), seed 0, started at t = 0 before the
    person moves. Measured over seeds 0-5: joint RMSE 13.9-16.0 deg, wrist RMSE 89-104 mm, the
    right arm's abduction 1.3-7.9 deg, the left's 1.3-1.9 (the left elbow, flexed 46 deg
    towards the camera, is held near 10: 33-38 deg). With the colour patches' references
    taken under the rest pose (``patch_refs: rest``) the right hand's patch learned the
    trousers beside it and held the arm down: R_SAA 23 deg, wrist 173-180 mm."""
    err, wrist = [], []
    for _, trk, _, truth, mean in _tracked_frames(["trackers.tbp.torso=truth"], 1.6, 45):
        body = trk.body
        err.append(mean - truth[6:])
        p_est = body.forward(mean[None], fixed=truth[:6])
        p_true = body.forward(truth[None, 6:], fixed=truth[:6])
        wrist += [(p_est.joint(w) - p_true.joint(w))[0] for w in ("r_wrist", "l_wrist")]
    per_dof = np.degrees(np.sqrt(np.mean(np.square(err), axis=0)))
    joints = np.degrees(np.sqrt(np.mean(np.square(err))))
    wrist_mm = 1e3 * np.sqrt(np.mean(np.sum(np.square(wrist), axis=1)))
    assert joints < 35.0, joints
    assert wrist_mm < 250.0, wrist_mm
    # seed 0 on 2026-11-29: joints 14.5 deg, wrist 98 mm, R_SAA 0.93 deg, L_SAA 1.9 deg
    assert per_dof[ARM_NAMES.index("R_SAA")] < 3.0, per_dof
    assert per_dof[ARM_NAMES.index("L_SAA")] < 5.0, per_dof


def test_arm_table_hands_in_the_image_match_the_posed_model():
    """The table's hands placed by the torso segment's rigid transform and projected equal
    the body model posed at that torso and projected by the camera model (an independent
    path: full forward kinematics and ``CameraModel.project_base``); blob neighbours equal
    a k-d tree's ball query; a re-drawn arm keeps the other arm and starts at rest."""
    from scipy.spatial import cKDTree

    from humimic.perception.trackers.tbp.reinit import (
        arm_table,
        draw_arms,
        hand_centres,
        hand_pixels,
        near_blobs,
    )
    from humimic.sensors.camera_model import CameraModel, Intrinsics

    body = avatar_body(torso="cylinder").with_free(ARM_NAMES)
    rng = np.random.default_rng(1)
    table = arm_table(body, 500, rng)
    torso = np.array([1.8, 0.2, 0.9, np.pi - 0.3, 0.1, -0.05])
    R_t, p_t = body.forward(np.zeros((1, 8)), fixed=torso).segment("torso")
    T_base_cam = np.eye(4)
    T_base_cam[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    T_base_cam[:3, 3] = [0.0, 0.05, 1.2]
    intr = Intrinsics(320, 240, 160.0, 160.0, 160.0, 120.0)
    cam = CameraModel("eye", intr, T_base_cam, T_base_cam)
    uv = hand_pixels(table, R_t[0], p_t[0], intr, cam.T_cam_base)
    want = cam.project_base(hand_centres(body, body.forward(table.q, fixed=torso)))
    np.testing.assert_allclose(uv, want, atol=1e-9)
    centres, radius = np.array([[150.0, 100.0], [170.0, 160.0]]), np.array([6.0, 9.0])
    tree = cKDTree(uv[0])
    got = near_blobs(uv[0], centres, radius)
    for g, c, r in zip(got, centres, radius, strict=True):
        assert sorted(g.tolist()) == sorted(tree.query_ball_point(c, r))
    assert sum(map(len, got)) > 0
    x = rng.normal(size=(50, 16))
    y, idx = draw_arms(x, table, [(1, got[0] if len(got[0]) else np.arange(5))], 10, 0.0, rng)
    keep = np.setdiff1d(np.arange(50), idx)
    np.testing.assert_array_equal(y[keep], x[keep])
    np.testing.assert_array_equal(y[idx][:, :4], x[idx][:, :4])         # the right arm kept
    np.testing.assert_array_equal(y[idx][:, 4:8], y[idx][:, 12:16])     # at rest
    assert all(any(np.allclose(r, t) for t in table.q[:, 4:8]) for r in y[idx][:, 4:8])


def test_tbp_finds_an_arm_already_waving_when_it_starts():
    """fig13's room with the person already waving the right hand beside the head (elbow
    flexed 70-147 deg) when TBP starts at the rest pose; torso from the truth, seed 0, 1 s.
    The skin blobs re-draw the lost arm (found on skin from frame 3) and the references wait
    until both hands are found. Scored over the second half second: the right hand's centre
    in the image, measured 1.4 px RMS (without re-drawing, ``reinit_fraction: 0``, the arm
    stays at rest: 63 px). In 3-D the wrist is still 0.35-0.43 m off on this seed: the hand
    on its blob, the arm at the wrong depth (one eye cannot tell)."""
    from humimic.perception.trackers.tbp.reinit import hand_centres

    px = []
    for k, trk, frame, truth, mean in _tracked_frames(
            ["trackers.tbp.torso=truth", 'human.motion={"kind": "wave"}'], 1.1, 30):
        if k >= 15:
            hands = [hand_centres(trk.body, trk.body.forward(q[None], fixed=truth[:6]))[0, 0]
                     for q in (mean, truth[6:])]
            uv = frame.camera.project_base(np.stack(hands))
            px.append(np.linalg.norm(uv[0] - uv[1]))
    hand_px = float(np.sqrt(np.mean(np.square(px))))
    assert hand_px < 2.0, hand_px  # measured 1.4, 0.74 px (2026-11-29)


def test_tbp_lost_arm_is_not_redrawn_onto_the_other_hand():
    """fig13_tbp_wave's own pipeline (seed 4, shoulders from the measured head) for its first
    1.6 s: the right hand is raised from rest faster than the particles follow, so its arm is
    re-drawn from the skin blobs. Blobs a hand of the estimate already lies on are not
    offered: drawn to the left hand's blob, the right arm crossed over at 1.07 s and stayed
    there (both hands on one blob score above the true raised arm). Right wrist RMSE over
    1.1-1.6 s: measured 44 mm, 452 mm when the left hand's blob was offered."""
    from humimic.perception.trackers.tbp.stage import TbpStage
    from humimic.pipeline.build import build_stages
    from humimic.pipeline.simulation import simulate
    from humimic.viz.rerun_log import RerunLog
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "fig13_tbp_wave.yaml", [], duration=1.6)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    try:
        with RerunLog(world.scene, "off", None, recording_id="test") as rlog:
            stages = build_stages(sc, world, rngs, rlog)
            simulate(world, stages, rlog, progress=False)
        tbp = next(s for s in stages if isinstance(s, TbpStage))
        t, err = tbp.error_series()["r_wrist"]
    finally:
        world.close()
    late = err[t > 1.1]
    assert len(late) >= 14 and np.isfinite(late).all()
    rmse_mm = 1e3 * float(np.sqrt(np.mean(late ** 2)))
    assert rmse_mm < 130.0, rmse_mm  # measured 44 mm (2026-11-29); 452 without the fix


def _tracked_frames(sets: list[str], duration: float, n: int):
    """TBP (seed 0) on fig13_tbp_clutter's first ``n`` frames at 30 Hz with ``sets``: yields
    ``(k, tracker, frame, true state in base, estimate)`` per frame."""
    from humimic.perception.trackers.tbp.build import tbp_stage
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "fig13_tbp_clutter.yaml", sets, duration=duration)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    stage = tbp_stage("tbp", sc.trackers["tbp"], sc, world, rngs, None)
    trk, rng = stage.tracker, np.random.default_rng(0)
    try:
        for k in range(n):
            tick = world.gt.index_of(k / 30)
            world.apply_human(tick)
            mujoco.mj_forward(world.scene.model, world.scene.data)
            frame = world.eye_rig.capture(k / 30)[stage.camera]
            truth = truth_state(world, tick, "base")
            mean, _, _ = trk.step(frame, truth[:6], rng)
            yield k, trk, frame, truth, mean
    finally:
        world.eye_rig.close()
