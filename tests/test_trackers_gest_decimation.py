"""GEST's per-frame image work on a decimated region of interest (``cue_radius_px``): the
decimated camera against OpenCV's area resize, the stereo cue unchanged by it, and tracking
with it."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from _synth_vision import clutter_background, stereo_head
from test_trackers_gest_tracking import HAND, _draw

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.gest.likelihood import blob_pair_log_likelihood
from humimic.perception.trackers.gest.roi import crop_frame, decimation, to_full_px, to_view_px
from humimic.perception.trackers.gest.tracker import GestTracker
from humimic.sensors.camera_model import CameraImage


def _spot(u: float, v: float, shape=(240, 320)) -> np.ndarray:
    y, x = np.mgrid[:shape[0], :shape[1]]
    return np.exp(-((x - u) ** 2 + (y - v) ** 2) / (2 * 4.0 ** 2)).astype(np.float32)


def _centroid(img: np.ndarray) -> np.ndarray:
    m = cv2.moments(img)
    return np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]])


def test_decimated_camera_projects_where_opencvs_area_resize_puts_a_point():
    """A smooth spot at a base-frame point's pixel, resized by ``cv2.INTER_AREA``: its
    centroid is where the decimated intrinsics project the point (< 0.01 px)."""
    cam, _ = stereo_head(k1=0.0, k2=0.0)
    for p, k in (([1.0, 0.1, 1.2], 2), ([1.3, -0.05, 1.1], 3), ([0.9, 0.0, 1.25], 4)):
        u, v = cam.project_base(np.array(p))
        K = cam.intrinsics.decimated(k)
        whole = _spot(u, v)[:K.height * k, :K.width * k]             # whole blocks
        small = cv2.resize(whole, (K.width, K.height), interpolation=cv2.INTER_AREA)
        want = _centroid(small)
        got = K.project((cam.T_cam_base @ np.r_[p, 1.0])[:3])
        np.testing.assert_allclose(got, want, atol=5e-8)  # measured 1.8e-8 px (was 0.01)
        assert (K.width, K.height) == (320 // k, 240 // k)


def test_a_decimated_crop_averages_blocks_and_maps_pixels_both_ways():
    cam, _ = stereo_head()
    frame = CameraImage(0.0, cam, clutter_background(np.random.default_rng(0)))
    box = (71, 20, 160, 121)                                   # trimmed to 88 x 100 by 2
    crop = crop_frame(frame, box, 2)
    assert crop.image.shape[:2] == (50, 44)
    block = frame.image[20 + 6:20 + 8, 71 + 10:71 + 12].astype(float).mean(axis=(0, 1))
    np.testing.assert_allclose(crop.image[3, 5], block, atol=0.51)     # rounding
    p = np.array([[1.0, 0.1, 1.2], [1.2, 0.0, 1.1]])
    full = cam.project_base(p)
    np.testing.assert_allclose(crop.camera.project_base(p),
                               to_view_px(full, np.array(box[:2], float), 2), atol=1e-9)
    np.testing.assert_allclose((full - box[:2] + 0.5) / 2 - 0.5,
                               crop.camera.project_base(p), atol=1e-9)
    np.testing.assert_allclose(to_full_px(to_view_px(full, np.array([3.0, 4.0]), 3),
                                          np.array([3.0, 4.0]), 3), full, atol=1e-12)
    assert crop_frame(frame, None) is frame


def test_block_size_keeps_the_hand_within_one_to_two_budgets():
    assert decimation(43.0, 12.0) == 3 and decimation(23.9, 12.0) == 1
    assert decimation(24.0, 12.0) == 2 and decimation(100.0, None) == 1
    assert decimation(math.nan, 12.0) == 1


def test_the_stereo_cue_in_decimated_pixels_is_the_full_resolution_one_plus_a_constant():
    """Centres and pairs mapped to block ``k``, sigma / k, outlier density * k^4 (two 2-D
    images): the same log-likelihood up to ``4 log k`` (what the tracker does)."""
    rng = np.random.default_rng(0)
    centres = rng.uniform(0, 300, (50, 2, 2))
    pairs = centres[rng.integers(0, 50, 3)] + rng.normal(0, 0.2, (3, 2, 2))
    full = blob_pair_log_likelihood(centres, pairs, 0.08, 1e-12)
    origin = np.array([[40.0, 10.0], [0.0, 0.0]])
    for k in (2, 3):
        got = blob_pair_log_likelihood(to_view_px(centres, origin, k),
                                       to_view_px(pairs, origin, k), 0.08 / k,
                                       1e-12 * k ** 4)
        np.testing.assert_allclose(got - 4 * np.log(k), full, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("cfg, foveal, k", [
    ({}, False, 1),                                            # defaults: wide at full res
    ({"cue_radius_px": 8.0, "foveal_cue_radius_px": None}, False, 2),
    ({"foveal_cue_radius_px": 8.0}, True, 2),
    ({"foveal_cue_radius_px": 8.0}, False, 1),                 # the foveal budget only there
])
def test_tracks_a_large_hand_image_on_decimated_cues(cfg, foveal, k):
    """A hand 22 px in radius (1 m from 60-degree eyes) moving 5 mm per frame, its cues at
    blocks of 2 (``cue_radius_px`` 8, or ``foveal_cue_radius_px`` 8 for frames ``step`` is
    told are the foveal pair's) from the second frame on. Measured (seeds 0-3): tracked
    throughout; the outline's mean distance to the edges 1.3-2.9 full-resolution px (at full
    resolution 0.9-2.9); the centre as at full resolution (from the full-resolution blobs),
    <= 14 mm off."""
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cams = stereo_head(k1=0.0, k2=0.0)
    bgs = [np.full((240, 320, 3), 70, np.uint8)] * 2
    path = [HAND + np.r_[0.0, 0.005 * i, 0.0, np.zeros(6)] for i in range(12)]
    trk = GestTracker(GestConfig(**cfg), lut)
    blocks: list[int] = []
    decimation = trk._decimation                    # spy on the block size step uses
    trk._decimation = lambda *a: blocks.append(decimation(*a)) or blocks[-1]
    rng = np.random.default_rng(0)
    err, fit = [], []
    for hand in path:
        res = trk.step(*_draw(bgs, cams, [hand]), rng, foveal=foveal)
        assert res.status == "tracking"
        err.append(np.linalg.norm(res.mean[:3] - hand[:3]))
        fit.append(res.shape_px * blocks[-1])                 # full-resolution px
    assert max(fit[1:]) < 5.0
    assert blocks == [1] + [k] * 11
    assert max(err) < 0.03
