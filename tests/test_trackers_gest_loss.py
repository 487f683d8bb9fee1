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
        # float32 points: measured <= 7.6e-7 and 1.9e-6 px (one ulp; 2026-11-29; was 1e-3)
        assert np.allclose([cx, cy], centre, atol=5e-6)
        assert np.allclose(sorted([w, h]), [2 * b, 2 * a], atol=5e-6)
        # OpenCV's angle is that of its first axis (w); the major axis is at th mod pi
        major = math.radians(ang) + (0.0 if w > h else math.pi / 2)
        assert abs(math.remainder(major - th, math.pi)) < 2e-7  # measured 5.7e-8 (was 1e-4)
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
    # measured 0.96 (0.65 before); 0.917 and 5.9 mm on 2026-11-29
    assert m["tracked_in_view_fraction"] >= 0.85
    assert m["position_rmse_mm"] < 15.0                            # measured 5.9
