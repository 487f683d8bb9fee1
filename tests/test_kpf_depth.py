"""The kpf's depth-aware proposal (``wrist_depth_move``) against closed-form geometry: the moved
wrist stays on the camera ray through the old one, its distance to the camera changes by the
requested amount, the shoulder and the other arm stay put, the segments keep their lengths and
the smallest-rotation helper matches scipy's ``Rotation.align_vectors``."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import (
    INTRINSICS,
    camera,
    facing_arm_poses,
    painted_person,
    propagated_wrist_ranges,
    static_pose,
)
from scipy.spatial.transform import Rotation

from humimic.maths.rotations import rotation_between
from humimic.perception.trackers.kpf.depth import (
    keep_wrist_range,
    reachable_range_change,
    wrist_depth_move,
)
from humimic.perception.trackers.kpf.tracker import kpf_body


def test_wrist_moves_along_its_camera_ray_by_delta():
    body = kpf_body()
    rng = np.random.default_rng(4)
    n = 200
    q = np.zeros((n, 14))
    q[:, 2], q[:, 3] = 0.0, np.pi                      # torso at the base origin, facing +x
    q[:, 6:10] = rng.uniform([-0.3, 0.1, -0.5, 0.3], [1.2, 1.2, 0.5, 1.5], (n, 4))
    q[:, 10:14] = rng.uniform([-0.3, 0.1, -0.5, 0.3], [1.2, 1.2, 0.5, 1.5], (n, 4))
    q = body.free_limits.clamp(q)
    delta = rng.uniform(-0.15, 0.15, n)
    T = camera()
    out = wrist_depth_move(body, q, "R", delta, T)
    moved = np.any(out != q, axis=1)
    assert moved.mean() > 0.5                           # most stay in reach and limits
    assert np.array_equal(out[:, :6], q[:, :6]) and np.array_equal(out[:, 10:], q[:, 10:])
    a, b = body.forward(q).to(T), body.forward(out).to(T)
    w0, w1 = a.joint("r_wrist")[moved], b.joint("r_wrist")[moved]
    # same ray (camera centre at the origin): parallel vectors; range changed by delta
    cos = np.sum(w0 * w1, 1) / np.linalg.norm(w0, axis=1) / np.linalg.norm(w1, axis=1)
    assert np.all(cos > 1 - 1e-10)
    np.testing.assert_allclose(np.linalg.norm(w1, axis=1) - np.linalg.norm(w0, axis=1),
                               delta[moved], atol=1e-9)
    np.testing.assert_allclose(a.joint("r_shoulder"), b.joint("r_shoulder"), atol=1e-12)
    for j0, j1 in (("r_shoulder", "r_elbow"), ("r_elbow", "r_wrist")):
        np.testing.assert_allclose(np.linalg.norm(b.joint(j1) - b.joint(j0), axis=1),
                                   np.linalg.norm(a.joint(j1) - a.joint(j0), axis=1), atol=1e-9)
    # untouched: out of reach or out of the joint limits
    assert np.all(body.free_limits.inside(out))


def test_keep_wrist_range_puts_the_wrist_at_the_reference_distance_on_its_own_ray():
    """``keep_wrist_range``: the moved wrist is on the camera ray through the unmoved one (its
    image kept) at the camera distance of the reference pose's wrist (plain vector norms in
    the camera frame), the shoulder fixed."""
    body = kpf_body()
    rng = np.random.default_rng(7)
    n = 200
    q = facing_arm_poses(body, rng, n, [-0.3, 0.1, -0.5, 0.3] * 2, [1.2, 1.2, 0.5, 1.5] * 2,
                         slice(6, 14))
    ref = body.free_limits.clamp(q + rng.uniform(-0.2, 0.2, q.shape) * (np.arange(14) >= 6))
    T = camera()
    out = keep_wrist_range(body, q, ref, "R", T)
    moved = np.any(out != q, axis=1)
    assert moved.mean() > 0.75  # measured 0.91 (was 0.5)
    a, b, r = (body.forward(x).to(T).joint("r_wrist") for x in (q, out, ref))
    cos = np.sum(a * b, 1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
    assert np.all(cos[moved] > 1 - 1e-10)
    np.testing.assert_allclose(np.linalg.norm(b[moved], axis=1),
                               np.linalg.norm(r[moved], axis=1), atol=1e-9)
    np.testing.assert_allclose(body.forward(out).joint("r_shoulder"),
                               body.forward(q).joint("r_shoulder"), atol=1e-12)


def test_reachable_range_change_clips_to_the_reach_found_by_a_scan():
    """``reachable_range_change``: a requested change along the wrist's camera ray within the
    arm's reach is kept, one beyond it is clipped to the farthest reachable point on that side
    (found independently by scanning the ray in 0.1 mm steps)."""
    body = kpf_body()
    rng = np.random.default_rng(3)
    n = 60
    q = facing_arm_poses(body, rng, n, [-0.3, 0.1, -0.5, 0.0], [1.2, 1.5, 0.5, 0.6])
    delta = rng.uniform(-0.4, 0.4, n)
    T = camera()
    c = np.linalg.inv(T)[:3, 3]
    got = reachable_range_change(body, q, "R", delta, c, margin=1e-3)
    pose = body.forward(q)
    S, W = pose.joint("r_shoulder"), pose.joint("r_wrist")
    R = (1 - 1e-3) * (body.skeleton.upper_arm + body.skeleton.forearm)
    t = np.arange(-0.6, 0.6, 1e-4)
    for k in range(n):
        u = (W[k] - c) / np.linalg.norm(W[k] - c)
        ok = t[np.linalg.norm(W[k] - S[k] + t[:, None] * u, axis=1) <= R]
        want = np.clip(delta[k], ok.min(), ok.max())
        assert got[k] == pytest.approx(want, abs=2e-4)


def test_rotation_between_matches_scipy():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    R = rotation_between(a, b)
    for k in range(50):
        ref, _ = Rotation.align_vectors(b[k][None], a[k][None])
        np.testing.assert_allclose(R[k], ref.as_matrix(), atol=1e-9)
    R = rotation_between(np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.array([[-2.0, 0, 0],
                                                                          [0, 3.0, 0]]))
    np.testing.assert_allclose(R[0] @ [1, 0, 0], [-1, 0, 0], atol=1e-12)
    assert np.linalg.det(R[0]) == pytest.approx(1.0)
    np.testing.assert_allclose(R[1], np.eye(3), atol=1e-12)


def test_tracker_with_depth_moves_and_rescue_holds_a_static_synthetic_person():
    """The tracker's extensions end to end on a rasterised body model (skin-coloured head and
    hands, distinct limb colours, a static pose): with depth moves and rescue passes (forced
    every frame) on, the estimate stays on the person: right wrist within 12 cm over 4 frames
    (measured 24-46 mm, seed 0; even this perfect image pins the depth only to a few cm)."""
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.cues import cue_maps
    from humimic.perception.trackers.kpf.tracker import KpfTracker

    body = kpf_body()
    intr, T, q0 = INTRINSICS, camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cfg = KpfConfig(n_particles=150, iterations=2, partitioned=True, torso_prior_m=0.03,
                    kde_stride=4, depth_share=0.3, rescue_passes=1, rescue_drop=0.01)
    tr = KpfTracker(body, intr, cfg, np.random.default_rng(0))
    maps = cue_maps(img, lut)
    tr.start(q0, maps, T)
    wrist = body.forward(q0[None]).joint("r_wrist")[0]
    for _ in range(4):
        res = tr.step(maps, T)
        assert np.all(np.isfinite(res.particles))
        err = np.linalg.norm(body.forward(res.mode[None]).joint("r_wrist")[0] - wrist)
        assert err < 0.12, err


def test_tracker_keep_range_puts_the_propagated_wrists_at_their_ancestors_distance(
        monkeypatch):
    """``keep_range_share`` 1 (both groups, the ancestors' distance, clipped) in the tracker:
    from the start pose (every ancestor the same), the particles handed to mean shift have
    their right wrist at the start pose's camera distance (plain norms in the camera frame)
    where the arm reaches it, while the plain walk spreads it by centimetres."""

    from humimic.perception.trackers.kpf.config import KpfConfig

    spread = {}
    for share in (0.0, 1.0):
        cfg = KpfConfig(n_particles=200, iterations=1, keep_range_share=share,
                        keep_range_groups="both", keep_range_target="ancestor",
                        keep_range_clip=True)
        r, r0 = propagated_wrist_ranges(monkeypatch, cfg)
        spread[share] = np.abs(r - r0)
    assert np.median(spread[0.0]) > 0.01                       # measured 0.023 m
    assert np.mean(spread[1.0] < 1e-6) > 0.6                   # measured 0.79 exact
    assert np.median(spread[1.0]) < 1e-6
