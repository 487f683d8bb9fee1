"""GEST's loss test (Menezes sec. 6.1, automatic recovery): the hand-sized ellipses it tries
against OpenCV's ellipse fit and the conic's gradient, and a dark hand near the robot, tracked
well but declared lost on a third of its frames while the test judged the (90 deg off)
orientation estimate."""

from __future__ import annotations

import math

import cv2
import numpy as np

from humimic.perception.trackers.gest.likelihood import ellipse_family


def test_ellipse_family_matches_opencvs_fit_and_the_conics_gradient():
    centre = np.array([40.3, 27.9])
    axes = np.array([[14.0, 6.0], [9.0, 4.5]])
    angles = np.array([0.0, 0.4, 2.0])
    fam = ellipse_family(centre, axes, angles, 40)
    assert fam.contour.shape == (6, 40, 2) and fam.normal.shape == (6, 40, 2)
    for row, ((a, b), th) in enumerate((ab, t) for ab in axes for t in angles):
        pts = fam.contour[row]
        (cx, cy), (w, h), ang = cv2.fitEllipse(pts.astype(np.float32))
        # float32 points: measured <= 7.6e-7 and 1.9e-6 px (one ulp; 2026-11-29; was 1e-3;
        # ~10x above: float32 rounding varies with the CPU's SIMD order)
        assert np.allclose([cx, cy], centre, atol=2e-5)
        assert np.allclose(sorted([w, h]), [2 * b, 2 * a], atol=2e-5)
        # OpenCV's angle is that of its first axis (w); the major axis is at th mod pi
        major = math.radians(ang) + (0.0 if w > h else math.pi / 2)
        assert abs(math.remainder(major - th, math.pi)) < 1e-6  # measured 5.7e-8 (was 1e-4)
        # outward normals: the gradient of (p - c)^T Q (p - c) with Q = R diag(a^-2, b^-2) R^T
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        Q = R @ np.diag([a ** -2, b ** -2]) @ R.T
        g = (pts - centre) @ Q
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        assert np.allclose(fam.normal[row], g, atol=1e-9)


def test_a_dark_hand_near_the_robot_is_not_declared_lost(tmp_path):
    """menezes_gest_far with the person 0.9 m away (hand 0.5-0.9 m) and skin (0.45, 0.30,
    0.22), seed 1: the dark hand has few edges against the shirt, the orientation estimate is
    75-105 deg off, and a loss test on the estimate's own ellipse (particles' mean centre)
    declared it lost on 35 % of the in-view frames while the published centre was 3-9 mm
    off (the true outline: skin-rim distance 0.00, edges 13-18 px away on a third of the
    frames). Measured after: tracked 0.96, 5.9 mm RMS (seeds 1, 3-6: 0.93-0.97, 5.6-6.0 mm;
    before 0.65-0.71, 6.1-6.4 mm)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sets = ["output.plots=false", "human.distance=0.9", "human.skin=[0.45,0.30,0.22]"]
    sc = load_scenario(SCENARIOS_DIR / "menezes_gest_far.yaml", sets, seed=1)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["gest"]
    # measured 0.96 (0.65 before); 0.917 and 5.9 mm on 2026-11-29, 0.942 and 6.0 mm with the
    # relative rim test (it lost the hand 3 frames fewer)
    assert m["tracked_in_view_fraction"] >= 0.85
    assert m["position_rmse_mm"] < 15.0                            # measured 5.9


def test_the_rim_fits_relative_to_the_skin_around_it():
    """The loss test's skin rim on a view without edges (the distance transform at its cap
    everywhere, so the rim decides): a hand whose skin posterior reads ``level`` over a
    background at a fifth of it fits at every level -- the own ellipse (:func:`rim_fits`)
    and the any-pose family alike -- where the absolute ``D_k = 1 - (inside - outside) <=
    0.5`` it replaces failed below ``level`` 0.625 (closed form: inside ``level``, outside
    ``level / 5``, ``D_k = 1 - 0.8 level``; a very dark hand's shaded rim read 0.48-0.79 in
    the 2-D hand tracker, which declared it lost while on it); skin on neither side (the
    hand gone) or on both (a skin-coloured wall) does not fit. The two sides against scipy's
    bilinear samples of the same map, ``RIM_OFFSET_PX`` along the normals."""
    import dataclasses

    from _synth_vision import stereo_head
    from scipy.ndimage import map_coordinates

    from humimic.perception.cues.edges import DT_CAP_PX
    from humimic.perception.trackers.gest.likelihood import (
        RIM_OFFSET_PX,
        hand_view,
        project_hands,
        shape_distance,
    )
    from humimic.perception.trackers.gest.loss import (
        any_pose_fits,
        lost_threshold_px,
        rim_fits,
    )
    from humimic.sensors.camera_model import CameraImage

    hand = np.array([1.0, 0.05, 1.15, 0.3, 0.2, 1.2, 0.045, 0.022, 0.08])
    cam, _ = stereo_head(k1=0.0, k2=0.0)
    blank = hand_view(CameraImage(0.0, cam, np.zeros((240, 320, 3), np.uint8)), 32)
    outline = project_hands(hand[None], blank, 64).contour[0]
    mask = np.zeros((240, 320), np.uint8)
    cv2.fillPoly(mask, [np.round(outline * 16).astype(np.int32)], 1, cv2.LINE_8, shift=4)
    no_edges = dataclasses.replace(blank.maps, dt=np.full((240, 320), DT_CAP_PX, np.float32))

    def view(skin):
        return dataclasses.replace(blank, maps=no_edges, skin=skin.astype(np.float32))

    def sides(skin, proj):
        c, n = proj.contour[0], proj.normal[0]
        return [map_coordinates(skin, [p[:, 1], p[:, 0]], order=1).mean()
                for p in (c - RIM_OFFSET_PX * n, c + RIM_OFFSET_PX * n)]

    proj = project_hands(hand[None], blank, 20)
    limit = lost_threshold_px(hand, blank, 5.0, 0.3)
    assert float(shape_distance(proj, view(mask))[0]) > limit       # the edges say lost
    for level in (1.0, 0.6, 0.45):
        skin = level * (0.2 + 0.8 * mask)
        inside, outside = sides(skin, proj)
        assert abs(inside - level) < 1e-6 and abs(outside - level / 5) < 1e-6
        assert (1.0 - (inside - outside) > 0.5) == (level < 0.625)    # the absolute test
        assert rim_fits(proj, view(skin), 2.0)[0]
        assert any_pose_fits(hand, proj, view(skin), 20, limit, 2.0)
    for skin in (np.zeros((240, 320)), np.full((240, 320), 0.6)):   # hand gone; skin all over
        inside, outside = sides(skin, proj)
        assert not inside >= 2.0 * outside > 0.0
        assert not rim_fits(proj, view(skin), 2.0)[0]
        assert not any_pose_fits(hand, proj, view(skin), 20, limit, 2.0)


def test_a_dark_hand_is_not_declared_lost_by_its_rims_skin_level(tmp_path):
    """menezes_gest_reach's first 2.1 s with skin (0.45, 0.30, 0.22), seed 1: at 1.9-2.0 s
    the hand's edges are 5.3-8.6 px from every hand-sized ellipse at the estimate (limit 5
    px) and the skin posterior just inside its best rim only 0.46-0.48 (outside ~0.0: the
    rim's inside 400x its outside). The absolute rim test (``1 - (inside - outside) <= 0.5``)
    declared it lost there twice while the estimate was 3.1 and 4.7 mm from the hand: 61 of
    63 frames tracked. The relative one (inside at least twice outside): all 63, 6.1 mm RMS.
    (Over the whole 4 s, seeds 0-4: frames lost 1, 4, 2, 1, 2 -> 1, 1, 2, 1, 2; the others
    by the stereo support test.)"""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sets = ["output.plots=false", "human.skin=[0.45,0.30,0.22]"]
    sc = load_scenario(SCENARIOS_DIR / "menezes_gest_reach.yaml", sets, seed=1, duration=2.1)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["gest"]
    assert m["in_view_frames"] == 63
    assert m["tracked_in_view_fraction"] >= 62 / 63                # measured 1.0 (61/63 before)
    assert m["position_rmse_mm"] < 15.0                            # measured 6.1
