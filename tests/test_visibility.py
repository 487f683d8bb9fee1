"""Visibility ground truth (in view, unoccluded fraction, size) and the scores built on it."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.spatial.distance import mahalanobis

from humimic.metrics.summary import verdict_warning
from humimic.metrics.visibility import cause, off_target
from humimic.paths import SCENARIOS_DIR
from humimic.perception.cues.auto_colors import look_alike_report
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.sensors.visibility import (
    VisibilityArrays,
    size_px,
    target_pixel_counts,
    unoccluded_fraction,
)
from humimic.world.world import World

GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


def test_target_pixel_counts_against_a_loop():
    rng = np.random.default_rng(0)
    seg = np.stack([rng.integers(-1, 8, (30, 40)), rng.choice([GEOM, 0], (30, 40))], axis=-1)
    geom_target = np.array([-1, 0, 0, 1, -1, 2, -1, 1])
    expected = [0, 0, 0]
    for oid, otype in seg.reshape(-1, 2):
        if otype == GEOM and 0 <= oid < 8 and geom_target[oid] >= 0:
            expected[geom_target[oid]] += 1
    np.testing.assert_array_equal(target_pixel_counts(seg, geom_target, 3), expected)


def test_fractions_and_sizes():
    np.testing.assert_allclose(unoccluded_fraction([50, 0, 12, 7], [100, 0, 12, 6]),
                               [0.5, 0.0, 1.0, 1.0])
    np.testing.assert_allclose(size_px([math.pi * 25.0]), [10.0])


def test_off_target_is_a_mahalanobis_test():
    rng = np.random.default_rng(1)
    centre = rng.normal(size=(20, 2)) * 10
    a = rng.normal(size=(20, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2) * 9 + np.eye(2)
    uv = centre + rng.normal(size=(20, 2)) * 8
    expected = [mahalanobis(u, c, np.linalg.inv(s)) > 3.0
                for u, c, s in zip(uv, centre, cov, strict=True)]
    np.testing.assert_array_equal(off_target(centre, cov, uv), expected)


def test_sample_lookup_and_causes():
    z = np.zeros((3, 1, 1), int)
    va = VisibilityArrays(["L"], ["head"], np.array([0.0, 0.2, 0.4]), z, z)
    np.testing.assert_array_equal(va.at([0.0, 0.19, 0.2, 0.5, -1.0]), [0, 0, 1, 2, 0])
    assert cause(0.0, None, None) == "out of view"
    assert cause(0.0, 0.05, 20.0) == "occluded"
    assert cause(1.0, 1.0, 8.2) == "too small: 8 px"
    assert cause(1.0, 1.0, 20.0) == "colour model mismatch"
    # blobs in both eyes whose name perception was not sure of: not a colour or size problem
    assert cause(1.0, 1.0, 20.0, unsure_share=0.97) == (
        "identity unsure: tracked in both eyes, name not sure on 97 % of the missed frames")
    assert cause(1.0, 1.0, 8.2, unsure_share=0.3) == "too small: 8 px"


def test_warning_line_names_poor_targets():
    m = {"tracking": {"head": {"verdict": "ok"},
                      "left_hand": {"verdict": "poor", "detection_rate": 0.0,
                                    "cause": "too small: 8 px"}}}
    assert verdict_warning(m) == ("warning: left_hand never detected (likely cause: too "
                                  "small: 8 px)")
    assert verdict_warning({"tracking": {"head": {"verdict": "poor", "detection_rate": None,
                                                  "cause": "out of view"}}}) == (
        "warning: head never visible (likely cause: out of view)")
    assert verdict_warning({"tracking": {"head": {"verdict": "ok"}}}) is None
    # a scene with look-alikes of the skin is named, poor targets or not
    colour = {"colour_warning": "the scene shows 2.14 pixels ..."}
    assert verdict_warning({**m, "perception": colour}) == (
        "warning: left_hand never detected (likely cause: too small: 8 px); the scene shows "
        "2.14 pixels ...")
    assert verdict_warning({"tracking": {}, "perception": colour}) == (
        "warning: the scene shows 2.14 pixels ...")
    # and each tracker's own skin model (trackers.<name>), after the blobs'
    trackers = {"kpf": {"frames": 3, **look_alike_report(3.14159)},
                "gest": look_alike_report(0.2), "face": {"frames": 3}}
    assert trackers["gest"] == {"skin_look_alike": 0.2} and look_alike_report(None) == {
        "skin_look_alike": None}
    assert verdict_warning({"tracking": {}, "perception": colour, "trackers": trackers}) == (
        "warning: the scene shows 2.14 pixels ...; kpf's skin model: the scene shows 3.14 "
        "pixels of the skin's colours per skin pixel (clothes or room of the skin's colour)")


@pytest.fixture(scope="module")
def hidden_world():
    scenario = load_scenario(SCENARIOS_DIR / "ude_hidden_target.yaml")
    world = World(scenario, Rngs(scenario.seed))
    yield world
    world.close()


def _sample_at(world, t: float):
    tick = int(round(t * world.clock.physics_rate))
    world.apply_human(tick)
    mujoco.mj_forward(world.scene.model, world.scene.data)
    vis = world.track_visibility()
    vis.sample(t)
    return vis.arrays()


def test_hand_behind_the_back_is_hidden(hidden_world):
    va = _sample_at(hidden_world, 2.5)  # the keyframes hold the hand behind the back
    j = va.target("right_hand")
    assert not va.visible[-1, :, j].any()
    assert (va.unoccluded[-1, :, j] < 0.1).all()  # measured 0.0
    va = _sample_at(hidden_world, 0.5)  # held up beside the head
    assert va.visible[-1, :, j].all() and (va.unoccluded[-1, :, j] > 0.9).all()


def test_head_size_matches_its_projected_ellipse(hidden_world):
    """The head's pixel count against the area of its silhouette, the ellipsoid's semi-axes
    (0.078 m wide, 0.115 m high, seen from the front) projected at the camera's distance."""
    va = _sample_at(hidden_world, 0.5)
    rig, world = hidden_world.eye_rig, hidden_world
    for c, cam in enumerate(va.cameras):
        model = rig.camera_model(cam)
        p_cam = np.linalg.inv(model.T_base_cam) @ np.append(world.gt.p_base("head")[
            int(0.5 * world.clock.physics_rate)], 1.0)
        intr = rig.intrinsics(cam)
        area = math.pi * (0.078 * intr.fx / p_cam[2]) * (0.115 * intr.fy / p_cam[2])
        # measured 0.98 of the area (pixel centres inside the outline)
        assert va.full_px[-1, c, va.target("head")] == pytest.approx(area, rel=0.06)


def test_reduced_resolution_counts_scale_back(hidden_world):
    """Cameras wider than MAX_WIDTH are sampled at a fraction of their resolution: the counts
    at half resolution, scaled back, agree with the full-resolution ones."""
    vis = hidden_world.track_visibility()
    full = _sample_at(hidden_world, 0.5).full_px[-1]
    vis.scale = 0.5
    try:
        half = _sample_at(hidden_world, 0.5).full_px[-1]
    finally:
        vis.scale = 1.0
    np.testing.assert_allclose(half, full, rtol=0.15)  # measured within 7 % (the small hand)


def test_scores_against_visibility_on_a_synthetic_record():
    """Ten frames; the target is reported in both eyes in every frame after the first two. The
    ground truth: visible in frames 0-5, hidden in 6-7 (both eyes), visible in 8-9 but the
    right eye's blob there sits 40 px from it (on something else)."""
    from humimic.metrics.visibility import visibility_scores
    from humimic.perception.blobs.record import PerceptionRecord
    from humimic.sensors.camera_model import Intrinsics

    intr = Intrinsics(320, 240, 200.0, 200.0, 159.5, 119.5)
    rec = PerceptionRecord(["right_hand"], ("L", "R"), (intr, intr))
    T = np.stack([np.eye(4), np.eye(4)])
    T[1, 0, 3] = 0.07
    p_true = np.tile([0.1, 0.0, 1.0], (10, 1))  # 1 m ahead of the (camera-frame) base
    uv = np.array([[179.5, 119.5], [165.5, 119.5]])  # its projections in L and R
    for f in range(10):
        seen = f >= 2
        centre = uv.copy()
        if f >= 8:
            centre[1, 0] += 40.0
        rec.append(f / 10, T, np.array([1]), np.array([[seen, seen]]), np.array([seen]),
                   centre[None], np.tile(4.0 * np.eye(2), (1, 2, 1, 1)), np.array([seen]),
                   [""], np.zeros((1, 3)), np.tile(np.eye(3), (1, 1, 1)),
                   np.zeros((1, 2, 2)), np.zeros(1))
    hidden = np.array([0] * 6 + [1, 1] + [0, 0], bool)
    px = np.where(hidden, 0.0, 100.0)[:, None, None] * np.ones((10, 2, 1))
    va = VisibilityArrays(["L", "R"], ["right_hand"], np.arange(10) / 10, px,
                          np.full((10, 2, 1), 100.0))
    s = visibility_scores(rec.arrays(), 0, "right_hand", va, p_true, warmup_s=0.0)
    assert s["visible_fraction"] == 0.8 and s["visible_frames"] == 8
    assert s["detection_rate"] == pytest.approx(6 / 8)  # frames 2-5 and 8-9 of 0-5, 8-9
    # false reports: both eyes in 6-7 (hidden), the right eye in 8-9 (off the target)
    assert s["false_detection_rate"] == pytest.approx(6 / 16)
    assert s["false_detections"] == 4
    # 6 of 16 reports false: more than FALSE_RATE, so the target is flagged all the same
    assert s["verdict"] == "poor" and s["cause"] == "false detections: 38 % of reports"
    assert s["median_unoccluded"] == 1.0


def test_a_target_tracked_in_both_eyes_but_never_named_surely_is_identity_unsure():
    """Ten visible frames; both eyes track the target's blob on it in every one, but its name
    is never sure (unconfirmed, so unmeasured): the verdict names the identity, not the colour
    model (which found the blob)."""
    from humimic.metrics.visibility import visibility_scores
    from humimic.perception.blobs.record import PerceptionRecord
    from humimic.sensors.camera_model import Intrinsics

    intr = Intrinsics(320, 240, 200.0, 200.0, 159.5, 119.5)
    rec = PerceptionRecord(["head"], ("L", "R"), (intr, intr))
    T = np.stack([np.eye(4), np.eye(4)])
    T[1, 0, 3] = 0.07
    p_true = np.tile([0.1, 0.0, 1.0], (10, 1))
    uv = np.array([[179.5, 119.5], [165.5, 119.5]])
    for f in range(10):
        rec.append(f / 10, T, np.array([2]), np.array([[True, True]]), np.array([False]),
                   uv[None], np.tile(4.0 * np.eye(2), (1, 2, 1, 1)), np.array([False]),
                   ["identity_unsure"], np.zeros((1, 3)), np.tile(np.eye(3), (1, 1, 1)),
                   np.zeros((1, 2, 2)), np.zeros(1))
    px = np.full((10, 2, 1), 150.0)
    va = VisibilityArrays(["L", "R"], ["head"], np.arange(10) / 10, px, px)
    s = visibility_scores(rec.arrays(), 0, "head", va, p_true, warmup_s=0.0)
    assert s["detection_rate"] == 0.0 and s["false_detection_rate"] == 0.0
    assert s["verdict"] == "poor" and s["cause"] == (
        "identity unsure: tracked in both eyes, name not sure on 100 % of the missed frames")


def test_a_run_that_ends_in_detection_phase_one_is_unscored_not_poor():
    """A run shorter than detection's phase one (``--duration 0.5`` of a scenario whose
    detection learns its threshold for 1 s) had no frame to judge: its targets are
    ``unscored`` and the warning line says why (before: ``poor``, "never visible (likely
    cause: colour model mismatch)" for a target in plain view)."""
    from humimic.metrics.visibility import visibility_scores
    from humimic.perception.blobs.record import PerceptionRecord
    from humimic.sensors.camera_model import Intrinsics

    intr = Intrinsics(320, 240, 200.0, 200.0, 159.5, 119.5)
    rec = PerceptionRecord(["head"], ("L", "R"), (intr, intr))
    T = np.stack([np.eye(4), np.eye(4)])
    T[1, 0, 3] = 0.07
    for f in range(5):
        rec.append(f / 10, T, np.array([0]), np.array([[False, False]]), np.array([False]),
                   np.zeros((1, 2, 2)), np.tile(np.eye(2), (1, 2, 1, 1)), np.array([False]),
                   ["not_seen"], np.zeros((1, 3)), np.tile(np.eye(3), (1, 1, 1)),
                   np.zeros((1, 2, 2)), np.zeros(1))
    px = np.full((5, 2, 1), 150.0)
    va = VisibilityArrays(["L", "R"], ["head"], np.arange(5) / 10, px, px)
    s = visibility_scores(rec.arrays(), 0, "head", va, np.tile([0.1, 0.0, 1.0], (5, 1)),
                          warmup_s=1.0)
    assert s["visible_fraction"] == 1.0 and s["detection_rate"] is None
    assert s["verdict"] == "unscored"
    assert s["cause"] == "the run ended in detection's phase one, its first 1 s"
    assert verdict_warning({"tracking": {"head": s}}) == (
        "warning: head not scored (the run ended in detection's phase one, its first 1 s)")


def test_label_counts_match_mujocos_segmentation(hidden_world):
    """The rig's counts straight from the id colours against MuJoCo's own segmentation image
    (Renderer's id -> (object id, type) conversion) counted per target: whole scene and
    targets alone, full and half resolution, hand hidden and shown."""
    vis = hidden_world.track_visibility()
    rig, n = hidden_world.eye_rig, len(vis.targets)
    for t in (0.5, 2.5):
        _sample_at(hidden_world, t)
        for cam in vis.cameras:
            for only in (None, vis.geoms):
                for scale in (1.0, 0.5):
                    want = target_pixel_counts(rig.render_ideal(cam, True, only, scale),
                                               vis.geom_target, n)
                    got = rig.label_counts(cam, vis.geom_target, n, only, scale)
                    np.testing.assert_array_equal(got, want)
                    assert want.sum() > 0


def test_tracker_scores_report_the_skin_its_table_lost():
    """A tracker's own learned skin table (``skin_lut``) reports what the blobs' does: the
    look-alike ratio and the share of the skin's pixels it lost, with the warning above
    ``LOST_WARN``."""
    from types import SimpleNamespace

    from humimic.perception.cues.auto_colors import LOST_WARN
    from humimic.perception.trackers.common import PoseTrackerStage

    class Fake(PoseTrackerStage):
        def scores(self):
            return {}

    stage = Fake("t")
    stage.skin_lut = SimpleNamespace(look_alike=0.1, class_lost=3 * LOST_WARN)
    out = stage.metrics()["trackers"]["t"]
    assert out["skin_look_alike"] == 0.1 and out["skin_lost"] == 3 * LOST_WARN
    assert "lost 15%" in out["colour_warning"]
