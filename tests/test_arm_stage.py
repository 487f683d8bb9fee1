"""The arm stage in the simulated room: the marker found in rendered frames, the Wii remote's
depth with the arm stretched forward (Sugiyama Fig. 3), the marker's shape read from the model,
and a scenario asking for the arm EKF without its sensors (exit 2, the key named)."""

from __future__ import annotations

import textwrap

import mujoco
import numpy as np
import pytest

from humimic.estimation.ekf.arm import ArmEKF, Marker
from humimic.estimation.ekf.arm_marker import MarkerBlob, marker_candidates
from humimic.estimation.ekf.arm_stage import choose_marker, marker_from_model
from humimic.paths import SCENARIOS_DIR
from humimic.run import main, run_one
from humimic.scenario import load_scenario
from humimic.sensors.camera_model import Intrinsics

K = Intrinsics.from_fovy(np.radians(50.0), 368, 240, -0.15, 0.02)


def test_marker_shape_from_the_model():
    sphere = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><geom name="m" type="sphere" size="0.02"/></body>'
        "</worldbody></mujoco>")
    assert marker_from_model(sphere, "m").radius == 0.02
    box = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><geom name="m" type="box" size="0.02 0.015 0.002"/></body>'
        "</worldbody></mujoco>")
    corners = marker_from_model(box, "m").corners
    np.testing.assert_allclose(np.abs(corners), [[0.02, 0.015, 0]] * 4)
    assert marker_from_model(box, "m").depth(1000.0, K) > 0


def _disc_image(centres_radii, shape=(240, 368)):
    import cv2

    img = np.full(shape + (3,), 128, np.uint8)
    for (u, v), r, colour in centres_radii:
        cv2.circle(img, (int(u), int(v)), int(r), colour, -1)
    return img


def test_candidates_undistort_and_keep_only_marker_shapes():
    import cv2

    red = (230, 20, 20)
    img = _disc_image([((250, 160), 12, red), ((80, 60), 20, red)])
    cv2.line(img, (10, 200), (150, 230), red, 5)  # a red stroke: not a marker's shape
    cands = marker_candidates(img, K)
    assert len(cands) == 2
    assert cands[0].pixels > cands[1].pixels  # largest first
    # the centroid and area are moved to the pinhole model (barrel distortion: outwards)
    for c in cands:
        r_d = np.linalg.norm(c.uv_distorted - [K.cx, K.cy])
        assert np.linalg.norm(c.uv - [K.cx, K.cy]) > r_d
        assert c.area > c.pixels


def test_the_filter_takes_the_region_it_predicts_not_the_largest():
    ekf = ArmEKF(K.pinhole(), Marker(radius=0.02))
    ekf.on_wii(0.0, np.zeros(3), np.array([0.0, 9.81, 0.0]), np.zeros(3), np.eye(3))
    small = MarkerBlob(np.array([200.0, 150.0]), 400.0, np.zeros(2), 400, (0, 0, 20, 20))
    big = MarkerBlob(np.array([60.0, 40.0]), 1500.0, np.zeros(2), 1500, (0, 0, 40, 40))
    far = MarkerBlob(np.array([60.0, 40.0]), 20.0, np.zeros(2), 20, (0, 0, 5, 5))
    # to start: the largest whose area puts it within reach (1500 px^2: 0.26 m; 20: 2.3 m)
    assert choose_marker(ekf, 0.0, [far, small], "predicted", (0.15, 1.2)) is small
    ekf.on_marker(0.0, small.uv, small.area, np.eye(3))
    assert choose_marker(ekf, 1 / 30, [big, small], "predicted", (0.15, 1.2)) is small
    assert choose_marker(ekf, 1 / 30, [big, small], "largest", (0.15, 1.2)) is big


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_depth_with_the_arm_stretched_forward(tmp_path, seed):
    """Sugiyama Fig. 3 (paper: ~3 cm; goal 1.5 cm), 5 s of the scenario, head pose oracle; the
    noise from the sensors makes the position covariance consistent (the paper's gave a
    position NEES of 0.09, the covariance ~30x too large)."""
    scenario = load_scenario(SCENARIOS_DIR / "sugiyama_fig3_arm_forward.yaml", duration=5.0,
                             overrides=["slam=null", "arm.head_pose=oracle"], seed=seed)
    m = run_one(scenario, tmp_path, rerun="off", progress=False)["arm"]
    assert m["measured_in_view_fraction"] > 0.98  # measured 0.993, 0.993
    assert m["false_marker_frames"] == 0
    assert m["depth_rmse_m"] < 0.02  # measured 0.0083, 0.0082 m (paper's noise: 0.010)
    assert m["position_rmse_m"] < 0.02  # measured 0.0089, 0.0088 m (paper's noise: 0.011)
    assert m["restarts"] == 0
    assert m["static_pitch_roll_updates"] > 100  # measured 259
    # position NEES (3 dof): measured 2.99, 2.94 (0.09 with the paper's noise)
    assert 1.5 < m["nees_position_mean"] < 6.0
    assert m["nees_position_in_band_fraction"] > 0.95  # measured 0.98, 0.98 (paper's: 0.09)
    # the orientation's error is its yaw, which nothing measures: the start's
    assert m["orientation_tilt_rmse_deg"] < 0.35  # measured 0.12, 0.13 deg
    # measured 15.5 deg: 125x, 117x the tilt
    assert abs(m["orientation_yaw_start_deg"]) > 40.0 * m["orientation_tilt_rmse_deg"]
    assert (tmp_path / "arm_position.png").is_file()


@pytest.mark.parametrize("sensors, key", [
    ("sensors: {head_camera: {enabled: false}}", "sensors.head_camera.enabled"),
    ("sensors: {head_camera: {enabled: true}, wiimote: {enabled: false}}",
     "sensors.wiimote.enabled"),
])
def test_arm_without_its_sensors_exits_2_naming_the_key(tmp_path, capsys, sensors, key):
    text = f"""\
    name: t
    duration: 0.1
    room: sugiyama
    human: {{wiimote: true}}
    cameras: {{enabled: false}}
    {sensors}
    arm: {{head_pose: oracle}}
    """
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent(text))
    code = main([str(path), "--out", str(tmp_path / "out"), "--rerun", "off", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and key in err, err


def test_arm_on_slam_without_slam_exits_2(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent("""\
    name: t
    room: sugiyama
    human: {wiimote: true}
    cameras: {enabled: false}
    sensors: {head_camera: {enabled: true}}
    arm: {head_pose: slam}
    """))
    code = main([str(path), "--out", str(tmp_path / "out"), "--rerun", "off", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "arm.head_pose" in err and "oracle" in err, err


def test_distortion_area_scale_is_the_jacobian_determinant():
    """Against finite differences of the camera model's own distortion (OpenCV's k1, k2)."""
    from humimic.estimation.ekf.arm_marker import distortion_area_scale

    def distort(xy):
        r2 = xy @ xy
        return xy * (1 + K.k1 * r2 + K.k2 * r2 * r2)
    for xy in (np.array([0.0, 0.0]), np.array([0.3, -0.2]), np.array([-0.5, 0.35])):
        h = 1e-6
        J = np.column_stack([(distort(xy + e) - distort(xy - e)) / (2 * h)
                             for e in (np.array([h, 0.0]), np.array([0.0, h]))])
        assert distortion_area_scale(xy, K) == pytest.approx(np.linalg.det(J), rel=1e-6)
