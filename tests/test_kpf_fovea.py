"""The kpf's second, foveal view of the arms (``trackers.<kpf>.fovea``,
:mod:`humimic.perception.trackers.kpf.fovea`) and the gaze that keeps it on the arm."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, painted_person, scenario_kpf, static_pose

from humimic.control.stage import POSE_JOINT
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.flips import arm_flips
from humimic.perception.trackers.kpf.fovea import (
    FovealLikelihood,
    decision_view,
    parts_in_view,
    two_view_terms,
    wrist_step,
)
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.scores import ENDPOINTS
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics

SIDE = "R"
ARM = ("r_upper_arm", "r_forearm", "r_hand")
CFG = KpfConfig(sigma_from_spread=False, colour_gradients=True,
                sigma={"edge": 0.25, "ridge": 0.4, "colour": 0.15, "skin": 0.4})


def fovea_camera() -> tuple[Intrinsics, np.ndarray]:
    """A narrow camera at the wide one's centre (:func:`_kpf_synth.camera`), f = 700 px
    (2.7x), turned to the raised right arm's elbow (the principal point on it)."""
    body, T, q0 = kpf_body(), camera(), static_pose()
    p = body.forward(q0[None]).to(T).joint("r_elbow")[0]    # in the wide camera's frame
    z = p / np.linalg.norm(p)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    R_cam_wide = np.stack([x, np.cross(z, x), z])           # rows: the new axes in the old
    Tf = np.eye(4)
    Tf[:3, :3], Tf[:3, 3] = R_cam_wide @ T[:3, :3], R_cam_wide @ T[:3, 3]
    return Intrinsics(320, 240, 700.0, 700.0, 159.5, 119.5), Tf


def views():
    body, T, q0 = kpf_body(), camera(), static_pose()
    fi, Tf = fovea_camera()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    img_w = painted_person(body, q0, T)
    import humimic.bodymodel as bm
    labels = bm.label_mask(bm.project(body, body.forward(q0[None]), fi, Tf))
    from _kpf_synth import PALETTE
    img_f = np.full((fi.height, fi.width, 3), 90, np.uint8)
    for p, name in enumerate(body.part_names):
        img_f[labels == p + 1] = PALETTE.get(name, (128, 128, 128))
    return body, q0, (FrameCues(img_w, lut, colour_gradients=True), T), \
        (FrameCues(img_f, lut, colour_gradients=True), Tf), fi


def test_two_view_terms_add_the_foveal_parts_only():
    rng = np.random.default_rng(0)
    w, f = rng.normal(size=(5, 8)), rng.normal(size=(5, 8))
    mask = np.array([0, 0, 1, 1, 1, 0, 0, 0], bool)
    got = two_view_terms(w, f, mask, 0.5)
    for i in range(5):   # the log of p_w(y_w | x) * prod_{l in fovea} p_f(l)^0.5, per row
        want = sum(w[i]) + 0.5 * (f[i, 2] + f[i, 3] + f[i, 4])
        assert got[i].sum() == pytest.approx(want)
    assert np.array_equal(got[:, ~mask], w[:, ~mask])


def test_foveal_likelihood_is_the_two_views_likelihoods_multiplied():
    body, q0, (mw, T), (mf, Tf), fi = views()
    rng = np.random.default_rng(1)
    q = np.repeat(q0[None], 6, axis=0)
    q[:, 6:10] += rng.normal(0.0, 0.15, (6, 4))
    two = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM)
    wide, fov = Likelihood(body, INTRINSICS, CFG), Likelihood(body, fi, CFG)
    two.adapt({p: c[0] for p, c in two.evaluate(q0[None], mw, T).colours.items()})
    wide.share_references(two.references)
    fov.share_references(two.references)
    ll_w = wide.evaluate(q, mw, T).log_lik
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w)     # before look(): wide only
    two.look(mf, Tf)
    t_f = fov.evaluate(q, mf, Tf).terms
    cols = [body.part_names.index(p) for p in ARM]
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w + t_f[:, cols].sum(1))
    two.look(None, None)
    assert np.allclose(two.evaluate(q, mw, T).log_lik, ll_w)


def test_the_foveal_view_separates_the_arms_flips():
    """On the painted scene (exact limb outlines), the truth's right-arm flips (same joint
    images in both cameras: they share the centre) cost more with the foveal view than in the
    wide view alone. Measured (2026-11-29) truth minus flip, nats, wide / two views: wrist
    flip 0.41 / 1.41, elbow flip 0.08 / 0.89, both 1.10 / 4.52 (gains 1.00 / 0.82 / 3.42)."""
    body, q0, (mw, T), (mf, Tf), fi = views()
    two = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM)
    two.adapt({p: c[0] for p, c in two.evaluate(q0[None], mw, T).colours.items()})
    c_ref = np.linalg.inv(T)[:3, 3]
    flips = arm_flips(body, q0[None], SIDE, c_ref)
    q = np.concatenate([q0[None], *[flips[k] for k in ("wrist", "elbow", "both")]])
    ok = np.all(np.isfinite(q), axis=1)
    assert ok.all(), "the test pose has all three flips"
    m_wide = two.evaluate(q, mw, T).log_lik
    two.look(mf, Tf)
    m_two = two.evaluate(q, mw, T).log_lik
    gain = (m_two[0] - m_two[1:]) - (m_wide[0] - m_wide[1:])
    assert np.all(gain > 0.3), gain


def test_gaze_can_follow_a_kpf_arm_joint():
    """``mimic.gaze.target: right_elbow`` with ``tracker: <kpf>`` looks up the pose's
    ``r_elbow`` (the kpf publishes shoulders, elbows and wrists, not hands)."""
    for target in ("right_elbow", "left_elbow", "right_wrist", "left_wrist"):
        assert POSE_JOINT[target] in ENDPOINTS


def test_fovea_parts_must_be_body_parts():
    body = kpf_body()
    with pytest.raises(ValueError, match="r_shin"):
        FovealLikelihood(body, INTRINSICS, CFG, INTRINSICS, ("r_forearm", "r_shin"))


def test_parts_in_view_needs_the_whole_outline_inside_the_margin():
    uv = np.array([[[10.0, 10.0], [300.0, 200.0]],      # inside a 320 x 240 image, 10 px in
                   [[10.0, 10.0], [315.0, 200.0]],      # 4 px from the right border
                   [[-5.0, 10.0], [100.0, 100.0]],      # a vertex off the image
                   [[50.0, 50.0], [60.0, 60.0]]])       # inside, but not valid
    valid = np.array([True, True, True, False])
    assert parts_in_view(uv, valid, 320, 240, 5.0).tolist() == [True, False, False, False]
    assert parts_in_view(uv, valid, 320, 240, 0.0).tolist() == [True, True, False, False]


def test_look_with_a_margin_scores_only_the_parts_in_view():
    """The scored parts are the foveal parts whose outline at the reference pose lies inside
    the foveal image (bounding boxes computed here); a margin no part fits leaves the wide
    view alone."""
    import humimic.bodymodel as bm
    body, q0, (mw, T), (mf, Tf), fi = views()
    two = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM)
    two.adapt({p: c[0] for p, c in two.evaluate(q0[None], mw, T).colours.items()})
    wide = Likelihood(body, INTRINSICS, CFG)
    wide.share_references(two.references)
    two.look(mf, Tf, q0, 1e3)
    assert not two.scored.any()
    assert np.allclose(two.evaluate(q0[None], mw, T).log_lik,
                       wide.evaluate(q0[None], mw, T).log_lik)
    uv = bm.project(body, body.forward(q0[None]), fi, Tf).outline.uv[0]
    lo, hi = uv.min(axis=1), uv.max(axis=1)
    want = [p in ARM and bool(np.all(lo[i] >= 2) and hi[i, 0] <= 317 and hi[i, 1] <= 237)
            for i, p in enumerate(body.part_names)]
    two.look(mf, Tf, q0, 2.0)
    assert two.scored.tolist() == want and any(want), (want, lo, hi)


def test_look_at_point_centres_a_point_in_both_coaxial_cameras():
    """``World.look_at_point`` (the profiler's ``--gaze``, ``TruthGaze``) turns the eyes so
    the point projects at the principal point of the eye's wide and foveal cameras; it holds
    (the servo target is set too) after physics steps."""
    import mujoco

    from humimic.paths import SCENARIOS_DIR
    from humimic.rngs import Rngs
    from humimic.scenario import load_scenario
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "schmidt_table1_fovgaze.yaml", seed=0, duration=0.2)
    world = World(sc, Rngs(0))
    try:
        p = world.gt.p_world("right_wrist")[0] + np.array([0.0, -0.1, 0.3])  # off the elbow
        world.look_at_point(p)
        m, d = world.scene.model, world.scene.data
        for _ in range(50):
            mujoco.mj_step(m, d)
        for cam in ("L_wide", "L_foveal"):
            model = world.eye_rig.camera_model(cam)
            uv = model.project_world(p[None])[0]
            i = model.intrinsics
            # measured 2026-11-29: 0 px to 1e-12 in both after 50 steps (a pose set without its
            # servo target drifts back towards the old one)
            assert np.allclose(uv, [i.cx, i.cy], atol=0.05), (cam, uv)
    finally:
        world.close()


def test_the_stage_tracks_with_both_views_and_the_eye_follows_it():
    """``schmidt_table1_fovgaze`` for 1 s at (150, 2): the kpf's likelihood is the two-view one
    with a foveal frame, and the gaze (on the kpf's elbow estimate) has turned the eye: the
    true elbow projects near the foveal image's centre (measured 2026-11-29 at t = 0.93 s,
    13.3 px: the person's arm hangs still, the estimate within a few cm)."""
    with scenario_kpf("schmidt_table1_fovgaze.yaml") as (world, kpf):
        assert isinstance(kpf.tracker.lik, FovealLikelihood) and kpf.tracker.lik.view
        model = world.eye_rig.camera_model("L_foveal")
        uv = model.project_world(world.gt.p_world("right_elbow")[world.gt.index_of(0.93)][None])
        i = model.intrinsics
        assert np.linalg.norm(uv[0] - [i.cx, i.cy]) < 40.0, uv


def test_decision_use_adds_the_fovea_only_while_deciding():
    """``fovea.use: decision``: the evaluations see the wide view alone, except inside
    ``deciding()`` (the flip-branch decision's), where they are ``use: all``'s two views;
    ``decision_view`` of a one-view likelihood changes nothing."""
    body, q0, (mw, T), (mf, Tf), fi = views()
    rng = np.random.default_rng(2)
    q = np.repeat(q0[None], 5, axis=0)
    q[:, 6:10] += rng.normal(0.0, 0.15, (5, 4))
    dec = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM, use="decision")
    wide, ll_w, ll_2 = _wide_and_both(dec, q, q0, mw, T, mf, Tf, fi)
    dec.look(mf, Tf)
    assert not np.allclose(ll_w, ll_2)
    assert np.allclose(dec.evaluate(q, mw, T).log_lik, ll_w)
    with decision_view(dec):
        assert np.allclose(dec.evaluate(q, mw, T).log_lik, ll_2)
    assert np.allclose(dec.evaluate(q, mw, T).log_lik, ll_w)
    with decision_view(wide):
        assert np.allclose(wide.evaluate(q, mw, T).log_lik, ll_w)
    with pytest.raises(ValueError, match="use"):
        FovealLikelihood(body, INTRINSICS, CFG, fi, ARM, use="mean_shift")


def _wide_and_both(lik, q, q0, mw, T, mf, Tf, fi):
    """``lik``'s colours adapted at ``q0``; a wide-only and a ``use: all`` likelihood with the
    same references; their log-likelihoods at ``q``: ``(wide, ll_wide, ll_both)``."""
    body = lik.body
    lik.adapt({p: c[0] for p, c in lik.evaluate(q0[None], mw, T).colours.items()})
    both = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM)
    wide = Likelihood(body, INTRINSICS, CFG)
    for other in (both, wide):
        other.share_references(lik.references)
    both.look(mf, Tf)
    return wide, wide.evaluate(q, mw, T).log_lik, both.evaluate(q, mw, T).log_lik


def test_the_branch_decision_scores_with_the_fovea_under_decision_use():
    """The flip-branch decision's ratios with ``use: decision`` are those of ``use: all``
    (both score the two views; refine_arms is deterministic) and not the wide view's."""
    from humimic.perception.trackers.kpf.tracker import KpfTracker

    body, q0, (mw, T), (mf, Tf), fi = views()
    cfg = CFG.model_copy(update={"n_particles": 20, "branch_threshold": 1e9,
                                 "branch_refine_polls": 1})
    r = {}
    for use in ("all", "decision", None):
        lik = None if use is None else FovealLikelihood(body, INTRINSICS, cfg, fi, ARM, use=use)
        tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(0), 7.5, lik)
        tr.start(q0, mw, T)
        if use is not None:
            lik.look(mf, Tf)
        tr.branches.step(tr, q0, mw, T)
        r[use] = tr.branches.history[-1][0][0]      # the right arm's ratios
    assert np.isfinite(r["all"]).any(), r
    assert np.allclose(r["decision"], r["all"], equal_nan=True), r
    assert not np.allclose(r[None], r["all"], equal_nan=True), r


def test_wrist_step_is_the_chord_of_an_elbow_turn():
    """Bending only the right elbow by ``a`` moves the right wrist on a circle of the
    forearm's length about the elbow: the chord ``2 L sin(a / 2)``; the left wrist stays."""
    body, q0 = kpf_body(), static_pose()
    q1 = q0.copy()
    q1[9] += 0.3                                             # R_EB
    pose = body.forward(q0[None])
    L = float(np.linalg.norm(pose.joint("r_wrist")[0] - pose.joint("r_elbow")[0]))
    assert wrist_step(body, q1, q0, ("r",)) == pytest.approx(2 * L * np.sin(0.15), rel=1e-9)
    assert wrist_step(body, q1, q0, ("l",)) == pytest.approx(0.0, abs=1e-12)


def test_moving_use_adds_the_fovea_while_the_estimated_arm_moves():
    """``use: moving``: the wide view alone while the foveal arm's wrist moved less than
    ``moving_m`` between the last two estimates (or there is no earlier one), both views once
    it moved more; the decision's evaluations always see both."""
    body, q0, (mw, T), (mf, Tf), fi = views()
    q_moved = q0.copy()
    q_moved[9] += 0.3                                        # the right wrist moves ~8 cm
    mov = FovealLikelihood(body, INTRINSICS, CFG, fi, ARM, use="moving", moving_m=0.02)
    _, ll_w, ll_2 = _wide_and_both(mov, q0[None], q0, mw, T, mf, Tf, fi)
    for q_prev, want in ((None, ll_w), (q0, ll_w), (q_moved, ll_2)):
        mov.look(mf, Tf, q0, None, q_prev)
        assert np.allclose(mov.evaluate(q0[None], mw, T).log_lik, want)
        with decision_view(mov):
            assert np.allclose(mov.evaluate(q0[None], mw, T).log_lik, ll_2)
