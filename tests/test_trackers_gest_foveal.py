"""GEST in the foveal pair (Menezes sec. 6.1 at the far end of 0.5-1.5 m): which pair it
measures in, the scale-relative loss test, rendering both kinds of eye camera, and the far
reach scenario's accuracy with the eyes gazing at GEST's own estimate."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
from _synth_vision import stereo_head
from test_scenario_errors import GOOD, _run

from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.gest.foveal import choose_pair, hand_inside
from humimic.perception.trackers.gest.tracker import lost_threshold_px
from humimic.sensors.camera_model import CameraImage, invert_transform
from humimic.sensors.config import Cameras
from humimic.world.world import eye_camera_names


def _opencv_uv(cam, p_base: np.ndarray) -> np.ndarray:
    """Pixel of a base-frame point by ``cv2.projectPoints`` (not the camera model's code)."""
    T = invert_transform(cam.T_base_cam)
    K = cam.intrinsics
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    uv, _ = cv2.projectPoints(p_base[None], rvec, T[:3, 3], K.K,
                              np.array([K.k1, K.k2, 0.0, 0.0]))
    return uv[0, 0]


def _narrow(cam, hfov_deg: float = 24.0):
    K = cam.intrinsics
    f = (K.width / 2) / np.tan(np.radians(hfov_deg) / 2)
    return dataclasses.replace(cam, intrinsics=dataclasses.replace(K, fx=f, fy=f, k1=0.0,
                                                                   k2=0.0))


def test_hand_inside_is_the_projected_circle_within_the_margin():
    """Against OpenCV's projection and the circle's radius ``fx r / depth`` in closed form,
    over random points near the image's border."""
    cam, _ = stereo_head()
    rng = np.random.default_rng(4)
    T = invert_transform(cam.T_base_cam)
    K = cam.intrinsics
    checked = 0
    for _ in range(300):
        p = np.array([rng.uniform(0.6, 1.8), rng.uniform(-0.9, 0.9), rng.uniform(0.5, 1.9)])
        depth = (T[:3, :3] @ p + T[:3, 3])[2]
        if depth <= 0.2:
            continue
        u, v = _opencv_uv(cam, p)
        r = K.fx * 0.08 / depth + 4.0
        want = r <= u <= K.width - r and r <= v <= K.height - r
        assert hand_inside(cam, p, 0.08, 4.0) == want
        checked += 1
    assert checked > 200
    behind = cam.T_base_cam[:3, 3] - 0.5 * cam.T_base_cam[:3, 2]
    assert not hand_inside(cam, behind, 0.08, 0.0)


def test_the_foveal_pair_only_while_the_estimate_is_in_its_view():
    wide = tuple(CameraImage(0.0, c, np.zeros((240, 320, 3), np.uint8)) for c in stereo_head())
    foveal = tuple(dataclasses.replace(f, camera=_narrow(f.camera)) for f in wide)
    ahead = np.r_[1.3, 0.0, 1.25, 0.0, 0.0, 0.0, 0.045, 0.022, 0.08]   # on the eyes' axes
    aside = ahead + np.r_[0.0, 0.4, 0.0, np.zeros(6)]                   # in the wide view only
    assert choose_pair(wide, foveal, ahead, 4.0) is foveal
    assert choose_pair(wide, foveal, aside, 4.0) is wide
    assert choose_pair(wide, foveal, None, 4.0) is wide                 # (re-)initialise wide
    assert choose_pair(wide, None, ahead, 4.0) is wide
    assert choose_pair(wide, (foveal[0], None), ahead, 4.0) is wide    # a frame missing
    near = ahead - np.r_[0.9, 0.0, 0.0, np.zeros(6)]                    # too big for it
    assert choose_pair(wide, foveal, near, 4.0) is wide


def test_loss_threshold_scales_with_the_hands_image():
    cam, _ = stereo_head(pan_l=0.0, tilt_l=0.0, k1=0.0, k2=0.0)
    axis = cam.T_base_cam[:3, 2]
    state = np.r_[cam.T_base_cam[:3, 3] + 1.5 * axis, 0.0, 0.0, 0.0, 0.045, 0.022, 0.08]
    fx = cam.intrinsics.fx
    assert np.isclose(lost_threshold_px(state, cam, 1.0, 0.3), 0.3 * fx * 0.08 / 1.5)
    assert lost_threshold_px(state, cam, 50.0, 0.3) == 50.0
    state[:3] = cam.T_base_cam[:3, 3] - axis                            # behind: the floor
    assert lost_threshold_px(state, cam, 5.0, 0.3) == 5.0


def test_both_kinds_of_eye_camera_are_rendered_wide_first():
    assert eye_camera_names(Cameras(which="both")) == ["L_wide", "R_wide", "L_foveal",
                                                       "R_foveal"]
    assert eye_camera_names(Cameras(which="foveal", eyes="left")) == ["L_foveal"]


@pytest.mark.parametrize("budget", [None, 12.0], ids=["full-res", "budget12"])
def test_far_reach_position_error(tmp_path, monkeypatch, budget):
    """menezes_gest_far (hand 1.24-1.56 m from the eyes), seed 3, first 2.5 s: measured
    8.9 mm RMS (2.9 median; the first frame, from the wide pair, 60 mm), tracked on every
    in-view frame, 99 % in the foveal pair. Over the whole 4 s, seeds 3-5: 8.8 mm (skins
    (0.45, 0.30, 0.22) and (0.55, 0.38, 0.28): 6.7-6.9; person at 0.9 / 1.5 / 2.0 m: 11.5 /
    6.3 / 6.0); the same run in the wide pair: 21 mm (this test fails it on the foveal
    fraction); the wide pair with the eyes still 22-23 mm (before the 16 px blob floor: 16-21
    mm on the 58-62 % of frames it tracked). With the blobs' hulls and the sphere offset
    (since), 7.7 mm (2.1 median), tracked on every in-view frame, 99 % foveal, with the
    foveal cue images at full resolution or at a 12 px hand radius (``foveal_cue_radius_px``,
    the default, blocks of 3 here) alike; the wide pair's frames at full resolution either
    way."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.perception.trackers.gest.tracker import GestTracker
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    blocks = {"L_wide": set(), "L_foveal": set()}      # block sizes the stage's frames used
    decimation = GestTracker._decimation

    def spy(self, frame, *args):
        k = decimation(self, frame, *args)
        blocks[frame.camera.name].add(k)
        return k

    monkeypatch.setattr(GestTracker, "_decimation", spy)
    sc = load_scenario(SCENARIOS_DIR / "menezes_gest_far.yaml",
                       ["output.plots=false", f"trackers.gest.foveal_cue_radius_px={budget}"
                        if budget else "trackers.gest.foveal_cue_radius_px=null"], duration=2.5)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["gest"]
    assert m["tracked_in_view_fraction"] >= 0.95
    assert m["foveal_tracked_fraction"] >= 0.96  # measured 0.987 (74 of 75 frames)
    assert m["position_rmse_mm"] < 20.0
    assert blocks["L_wide"] == {1}
    assert blocks["L_foveal"] == ({1} if budget is None else {3})


def test_near_reach_position_error(tmp_path):
    """menezes_gest_far with the person at 0.9 m (hand 0.5-0.9 m from the eyes, 40-50 % of
    the frames in the wide pair), seed 6, first 3.2 s (the hand raised, nearest the lamp):
    6.2 mm RMS (whole 4 s, seeds 0-9: 5.8-6.2). Without the blobs' hulls, the lit skin in the
    skin model (``skin_gains``) and the orientation-free silhouette offset: 12.7 (whole 4 s,
    seeds 0-9: 10.2-16.3; the lit hand's saturated pixels were no skin and bit into its
    blobs)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_gest_far.yaml",
                       ["output.plots=false", "human.distance=0.9"], seed=6, duration=3.2)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["gest"]
    # measured 2026-11-29: tracked on 95 of 96 frames (0.990), 6.1 mm RMS
    assert m["tracked_in_view_fraction"] >= 0.97
    assert m["position_rmse_mm"] < 10.0


@pytest.mark.parametrize("bad", [{"blob_min_area_px": 0.5}, {"lost_rel": -0.1},
                                 {"foveal_margin_px": -1.0}, {"foveal": ["L_foveal"]},
                                 {"cue_radius_px": 0.0}, {"foveal_cue_radius_px": -1.0}])
def test_bad_foveal_settings_are_rejected(bad):
    with pytest.raises(ValueError):
        GestConfig(**bad)


@pytest.mark.parametrize("text, must_contain", [
    (GOOD + "trackers:\n  g: {kind: gest, foveal: [L_foveal, R_foveal]}\n",
     ["trackers.g.foveal.0", "'L_foveal'", "not rendered"]),
    (GOOD + "cameras: {which: both}\nmimic:\n  gaze: {enabled: true, target: right_hand, "
     "tracker: gest}\n", ["mimic.gaze.tracker", "no such tracker", "'gest'"]),
])
def test_bad_foveal_input_exits_2_naming_the_key(tmp_path, capsys, text, must_contain):
    code, err = _run(tmp_path, text, capsys=capsys)
    assert code == 2
    assert len(err.splitlines()) == 1, err
    for piece in must_contain:
        assert piece in err, f"{piece!r} not in {err!r}"


def test_covering_an_eye_covers_both_its_cameras_when_both_are_rendered():
    from humimic.paths import SCENARIOS_DIR
    from humimic.rngs import Rngs
    from humimic.scenario import load_scenario
    from humimic.world.world import World

    sc = load_scenario(SCENARIOS_DIR / "static.yaml",
                       ["cameras.which=both", "cameras.covered=[{camera: left, start: 0, end: 1}]"])
    w = World(sc, Rngs(0))
    assert w.eye_cameras == ["L_wide", "R_wide", "L_foveal", "R_foveal"]
    assert w.faults.frames.covered == {"L_wide": [(0.0, 1.0)], "L_foveal": [(0.0, 1.0)]}
