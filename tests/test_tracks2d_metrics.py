"""Image-space tracker scores (metrics/tracks2d.py) on synthetic series with known answers."""

import cv2
import numpy as np

from humimic.messages import TRACK_STATES, Track2D, Tracks2D
from humimic.metrics.tracks2d import (
    ImageTruth,
    project_truth,
    reacquire_times,
    rising_edges,
    scores,
)
from humimic.sensors.camera_model import CameraModel, Intrinsics, make_transform


def _camera(k1=0.0):
    intr = Intrinsics(320, 240, 200.0, 200.0, 159.5, 119.5, k1)
    R = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]).T  # base <- cv
    return CameraModel("c", intr, make_transform(R, np.array([0.0, 0.0, 1.0])))


def test_projection_matches_opencv():
    cam = _camera(k1=-0.1)
    p_base = np.array([[2.0, 0.3, 1.2], [1.5, -0.2, 0.9], [-1.0, 0.0, 1.0]])
    truth = project_truth([cam] * 3, p_base, size_m=0.1)
    T = np.linalg.inv(cam.T_base_cam)
    rvec, _ = cv2.Rodrigues(T[:3, :3])
    ref, _ = cv2.projectPoints(p_base[:2], rvec, T[:3, 3], cam.intrinsics.K,
                               cam.intrinsics.dist)
    np.testing.assert_allclose(truth.uv[:2], ref[:, 0], atol=1e-9)
    depth = (p_base[:2] @ T[:3, :3].T + T[:3, 3])[:, 2]
    np.testing.assert_allclose(truth.size_px[:2], 200.0 * 0.1 / depth)
    assert truth.visible.tolist() == [True, True, False]  # the last is behind the camera


def _truth(n, visible):
    return ImageTruth(np.tile([100.0, 100.0], (n, 1)), np.full(n, 20.0), np.asarray(visible))


def test_rising_edges_and_reacquire():
    assert rising_edges([True, True, False, True, False, False, True]).tolist() == [0, 3, 6]
    t = np.arange(10) * 0.1
    vis = np.array([1, 1, 0, 0, 1, 1, 1, 0, 1, 1], bool)
    on = np.array([0, 1, 0, 0, 0, 0, 1, 0, 0, 0], bool)
    acq, re = reacquire_times(t, vis, on)
    assert np.isclose(acq, 0.1)
    assert np.isclose(re[0], 0.2) and np.isnan(re[1])  # second return never re-acquired


def test_scores_lost_wrong_person_and_errors():
    n = 10
    t = np.arange(n) / 10.0
    truth = _truth(n, np.ones(n, bool))
    other = ImageTruth(np.tile([200.0, 100.0], (n, 1)), np.full(n, 20.0), np.ones(n, bool))
    est = np.tile([103.0, 104.0], (n, 1))  # 5 px off
    est[4:7] = [201.0, 100.0]  # three frames on the other person
    tracking = np.ones(n, bool)
    tracking[8] = False
    s = scores(t, est, np.full(n, 22.0), tracking, truth, [other])
    assert s["identity_switches"] == 1 and s["wrong_person_frames"] == 3
    assert np.isclose(s["lost_fraction"], 4 / 10)  # 3 on the other + 1 not tracking
    assert np.isclose(s["on_target_rmse_px"], 5.0)
    judged = np.r_[np.full(6, 5.0), np.full(3, np.hypot(101.0, 0.0))]
    assert np.isclose(s["center_rmse_px"], np.sqrt(np.mean(judged**2)))
    assert np.isclose(s["scale_rmse_px"], 2.0)
    assert s["false_track_fraction"] is None and s["acquire_s"] == 0.0


def test_scores_of_a_target_never_tracked_in_view():
    """The target hidden whenever the tracker tracks (it followed the other hand; a hand
    never found): no judged frame, the errors None -- ``scale_rmse_px`` over no frames had
    raised (``menezes_hand_people --set trackers.hand.target=left_hand``: a traceback, exit
    1, no metrics.json)."""
    n = 6
    visible = np.array([1, 1, 1, 0, 0, 0], bool)
    tracking = ~visible
    s = scores(np.arange(n) / 10.0, np.tile([100.0, 100.0], (n, 1)), np.full(n, 20.0),
               tracking, _truth(n, visible))
    assert s["center_rmse_px"] is None and s["scale_rmse_px"] is None
    assert s["center_median_px"] is None and s["lost_fraction"] == 1.0
    assert s["false_track_fraction"] == 1.0


def test_track_messages():
    tr = Track2D("right_hand", 10.0, 20.0, 15.0, state="lost")
    msg = Tracks2D("hand", "L_wide", (tr,))
    assert msg.tracks[0].state in TRACK_STATES and np.isnan(tr.confidence)
