"""The kpf's local refinement of the mode: the batched pattern search against closed forms and
scipy.optimize, the arm's depth direction against the camera-ray geometry, the per-arm
refinement on a closed-form objective of the wrists, and the likelihood's fixed-sigma
evaluation against eqs. 9-10 written out from the costs."""

from __future__ import annotations

import numpy as np
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose
from scipy.optimize import minimize

from humimic.maths.pattern_search import pattern_search
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf import cues as C
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.refine import depth_direction, refine_arms
from humimic.perception.trackers.kpf.tracker import kpf_body


def _quadratic(A: np.ndarray, b: np.ndarray):
    return lambda x: -0.5 * np.einsum("mi,ij,mj->m", x, A, x) + x @ b


def test_pattern_search_reaches_a_quadratics_closed_form_maximum():
    rng = np.random.default_rng(0)
    M = rng.normal(size=(4, 4))
    A = M @ M.T + 0.5 * np.eye(4)                 # correlated, positive definite
    b = rng.normal(size=4)
    f = _quadratic(A, b)
    x_star = np.linalg.solve(A, b)
    x0 = x_star + rng.normal(size=4)
    res = pattern_search(f, x0, np.eye(4), np.full(4, 0.5), polls=400)
    assert res.value >= res.start_value
    assert res.evaluations == 1 + 400 * 8
    np.testing.assert_allclose(res.x, x_star, atol=2e-8)   # measured 5.1e-9 (was 1e-3)
    # a few polls: uphill, never below the start
    short = pattern_search(f, x0, np.eye(4), np.full(4, 0.5), polls=3)
    assert res.value >= short.value >= short.start_value
    assert short.value == f(short.x[None])[0]


def test_pattern_search_projected_matches_scipys_bounded_optimum():
    rng = np.random.default_rng(1)
    M = rng.normal(size=(3, 3))
    A = M @ M.T + np.eye(3)
    b = 3.0 * rng.normal(size=3)
    f = _quadratic(A, b)
    lo, hi = -0.2 * np.ones(3), 0.2 * np.ones(3)
    ref = minimize(lambda x: -f(x[None])[0], np.zeros(3), method="L-BFGS-B",
                   bounds=list(zip(lo, hi, strict=True)))
    # the same search with the depth-like diagonal direction added
    dirs = np.vstack([np.eye(3), np.ones(3) / np.sqrt(3)])
    res = pattern_search(f, np.zeros(3), dirs, np.full(4, 0.1), polls=200,
                         project=lambda c: np.clip(c, lo, hi))
    assert np.all((res.x >= lo) & (res.x <= hi))
    np.testing.assert_allclose(res.value, -ref.fun, atol=1e-6)
    np.testing.assert_allclose(res.x, ref.x, atol=2e-8)    # measured 5.8e-9 (was 1e-3)


def test_pattern_search_ignores_non_finite_values():
    def f(x):
        v = -np.sum((x - 1.0) ** 2, axis=1)
        return np.where(x[:, 0] > 0.5, np.nan, v)    # the way to the optimum is NaN
    res = pattern_search(f, np.zeros(2), np.eye(2), np.full(2, 1.0), polls=50)
    assert np.isfinite(res.value) and res.x[0] <= 0.5
    np.testing.assert_allclose(res.x, [0.5, 1.0], atol=1e-12)  # the best finite point, exactly
    # a non-finite start is left for the first finite candidate (it blocked the search)
    start = pattern_search(f, np.array([0.6, 0.0]), np.eye(2), np.full(2, 0.5), polls=50)
    assert np.isfinite(start.value) and start.x[0] <= 0.5


def _ray(body, q, T, side="r"):
    c = np.linalg.inv(T)[:3, 3]
    w = body.forward(q[None]).joint(f"{side}_wrist")[0]
    return w, (w - c) / np.linalg.norm(w - c)


def test_depth_direction_moves_the_wrist_along_its_camera_ray():
    body, T = kpf_body(), camera()
    q = static_pose()
    q[6:10] = [0.5, 0.6, 0.2, 0.8]
    for side, j, pre in (("R", 6, "r"), ("L", 10, "l")):
        u = depth_direction(body, q, side, T)
        assert u is not None and np.linalg.norm(u) > 0.1
        w0, ray = _ray(body, q, T, pre)
        eps = 1e-4
        q1 = q.copy()
        q1[j:j + 4] += eps * u
        w1, _ = _ray(body, q1, T, pre)
        # the central difference over +-2 mm: measured < 0.2 % off the ray step
        np.testing.assert_allclose(w1 - w0, eps * ray, atol=1e-2 * eps)


def test_refine_arms_climbs_a_closed_form_wrist_objective():
    body, T = kpf_body(), camera()
    q_true = static_pose()
    q_true[6:10] = [0.5, 0.6, 0.2, 0.8]
    targets = {s: body.forward(q_true[None]).joint(f"{s}_wrist")[0] for s in ("r", "l")}

    def f(q):
        pose = body.forward(q)
        return -sum(np.sum((pose.joint(f"{s}_wrist") - t) ** 2, axis=1)
                    for s, t in targets.items()) / 0.01 ** 2
    q0 = q_true.copy()
    q0[6:14] += np.radians([4, -3, 5, 4, -3, 2, 3, -4])
    D = np.asarray(KpfConfig().D(), float)
    out, n = refine_arms(body, q0, f, D, T, polls=30, step=0.1, depth_step_m=0.02,
                         limits=body.free_limits)
    assert n == 2 * (1 + 30 * 10)                 # 4 DOFs + the depth direction, +-, per arm
    np.testing.assert_array_equal(out[:6], q0[:6])
    before, after = f(q0[None])[0], f(out[None])[0]
    assert after > before
    for s in ("r", "l"):
        e0 = np.linalg.norm(body.forward(q0[None]).joint(f"{s}_wrist")[0] - targets[s])
        e1 = np.linalg.norm(body.forward(out[None]).joint(f"{s}_wrist")[0] - targets[s])
        # measured 12, 16 um from 60, 50 mm (2026-11-29; the bound was 0.3 mm)
        assert e0 > 0.02 and e1 < 5e-5
    right, n = refine_arms(body, q0, f, D, T, polls=30, step=0.1, depth_step_m=0.02,
                           limits=body.free_limits, sides=("R",))
    assert n == 1 + 30 * 10                        # one arm's polls
    np.testing.assert_array_equal(right[10:], q0[10:])
    np.testing.assert_array_equal(right[6:10], out[6:10])   # the right arm's first, as before


def test_fixed_sigma_evaluation_is_eqs_9_10_with_the_floors():
    body, T = kpf_body(), camera()
    q0 = static_pose()
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    maps = C.cue_maps(painted_person(body, q0, T), lut)
    cfg = KpfConfig(sigma_from_spread=True,      # floors below the particles' spread
                    sigma={"edge": 0.02, "ridge": 0.02, "colour": 0.02, "skin": 0.02})
    lik = Likelihood(body, INTRINSICS, cfg)
    rng = np.random.default_rng(2)
    q = q0 + rng.normal(0, 0.1, (40, 14)) * (np.arange(14) >= 6)
    spread, fixed = lik.evaluate(q, maps, T), lik.evaluate(q, maps, T, floors=True)
    expected = np.zeros(len(q))
    for p, part in enumerate(lik.parts):
        used = lik.use[part]
        for c in used:
            e = fixed.cost[c][:, p]
            expected -= e ** 2 / (2 * getattr(cfg.sigma, c) ** 2) / len(used)
    np.testing.assert_allclose(fixed.log_lik, expected, rtol=1e-12)
    assert not np.allclose(spread.log_lik, expected)     # the spread's sigmas differ


def test_tracker_reports_the_refined_mode_no_worse_than_mean_shifts_and_injects_it():
    """Two trackers on the same random stream, a rasterised person with the arms moved off the
    start pose: the refined tracker's first estimate scores (eqs. 9-10 at the floors, written
    out here) at least the plain one's, and sits in its particle set."""
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker

    body, T = kpf_body(), camera()
    q_img = static_pose()
    q_start = q_img.copy()
    q_start[6:14] += np.radians([8, -6, 10, 8, 5, -5, 6, 5])
    img = painted_person(body, q_img, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    modes, trackers = {}, {}
    for polls in (0, 6):
        cfg = KpfConfig(n_particles=150, iterations=2, kde_stride=4, refine_polls=polls,
                        sigma_from_spread=False)
        tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(3))
        tr.start(q_start, FrameCues(img, lut), T)
        out = tr.step(FrameCues(img, lut), T)
        modes[polls] = out.mode
        trackers[polls] = tr
        if polls:   # the refined mode leads the displayed modes
            np.testing.assert_array_equal(out.modes[0], out.mode)
    maps = C.cue_maps(img, lut)
    lik = Likelihood(body, INTRINSICS, cfg)          # the references as at the refinement
    lik.adapt({p: c[0] for p, c in lik.evaluate(q_start[None], maps, T).colours.items()})
    ll = lik.evaluate(np.stack([modes[0], modes[6]]), maps, T).log_lik
    assert ll[1] >= ll[0]
    assert not np.array_equal(modes[0], modes[6])
    np.testing.assert_allclose(modes[0][:6], modes[6][:6], atol=1e-8)   # torso not searched
    assert np.any(np.all(trackers[6].particles == modes[6], axis=1))
    # with per-particle velocities the injected particle has none of its own (not the
    # replaced particle's)
    tv = KpfTracker(body, INTRINSICS, cfg.model_copy(update={"particle_velocity": True}),
                    np.random.default_rng(3))
    tv.start(q_start, FrameCues(img, lut), T)
    for _ in range(2):
        mode = tv.step(FrameCues(img, lut), T).mode
        injected = np.all(tv.particles == mode, axis=1)
        assert np.any(injected) and not np.any(tv.pvel[injected])
        assert np.count_nonzero(np.any(tv.pvel != 0.0, axis=1)) > 0.5 * len(tv.pvel)
    np.testing.assert_allclose(trackers[6].W.sum(axis=0), 1.0)
    # report only: the same tracking as the plain tracker's, the refined estimate reported
    cfg = KpfConfig(n_particles=150, iterations=2, kde_stride=4, refine_polls=6,
                    sigma_from_spread=False, refine_feedback=False)
    tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(3))
    ref = KpfTracker(body, INTRINSICS, cfg.model_copy(update={"refine_polls": 0}),
                     np.random.default_rng(3))
    for t in (tr, ref):
        t.start(q_start, FrameCues(img, lut), T)
    for _ in range(2):
        res = tr.step(FrameCues(img, lut), T)
        plain = ref.step(FrameCues(img, lut), T)
    # equal to rounding: the refinement's evaluations widen the frame's lazily computed cue
    # maps, whose values differ at ~1e-11 near a computed region's border
    np.testing.assert_allclose(tr.particles, ref.particles, atol=1e-8)
    np.testing.assert_allclose(tr.mode, plain.mode, atol=1e-8)
    assert not np.array_equal(res.mode, plain.mode)
