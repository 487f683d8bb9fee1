"""The SLAM stage in the pipeline: its scenario section (bad values and missing sensors exit 2
with one line naming the key), the head_pose topic, and its scores on short runs of the
paper's room."""

from __future__ import annotations

import json
import math
import textwrap

import numpy as np
import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.run import main, run_one
from humimic.scenario import load_scenario

WEARABLE = """\
name: t
duration: 0.2
room: sugiyama
cameras: {enabled: false}
sensors:
  head_camera: {enabled: true}
slam: {}
output: {plots: false}
"""


def _run(tmp_path, text, capsys, *extra):
    path = tmp_path / "s.yaml"
    path.write_text(textwrap.dedent(text))
    code = main([str(path), "--out", str(tmp_path / "out"), "--rerun", "off", "--quiet",
                 *extra])
    return code, capsys.readouterr().err.strip()


@pytest.mark.parametrize("text, must_contain", [
    (WEARABLE.replace("slam: {}", "slam: {mode: fusoin}"),
     ["slam.mode", "'fusoin'", "did you mean 'fusion'"]),
    (WEARABLE.replace("slam: {}", "slam: {target_features: -3}"),
     ["slam.target_features", "out of range"]),
    (WEARABLE.replace("slam: {}", "slam: {noise: {jerk: 0}}"), ["slam.noise.jerk"]),
    (WEARABLE.replace("slam: {}", "slam: {patch_pixels: 9}"),
     ["slam.patch_pixels", "unknown key", "did you mean 'patch_px'"]),
    (WEARABLE.replace("head_camera: {enabled: true}", "head_camera: {enabled: false}"),
     ["sensors.head_camera.enabled", "needs the head camera"]),
    (WEARABLE.replace("head_camera: {enabled: true}",
                      "head_camera: {enabled: true}\n  imu: {enabled: false}"),
     ["sensors.imu.enabled", "needs the head IMU"]),
    (WEARABLE.replace("head_camera: {enabled: true}",
                      "head_camera: {enabled: true}\n  imu: {orientation: false}"),
     ["sensors.imu.orientation", "use_orientation"]),
])
def test_bad_slam_scenario_exits_2_naming_the_key(tmp_path, capsys, text, must_contain):
    code, err = _run(tmp_path, text, capsys)
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    for piece in must_contain:
        assert piece in err, f"{piece!r} not in {err!r}"


def test_sensor_needs_follow_the_mode(tmp_path, capsys):
    """Camera-only SLAM runs without the IMU; inertial-only without the head camera."""
    no_imu = WEARABLE.replace("head_camera: {enabled: true}",
                              "head_camera: {enabled: true}\n  imu: {enabled: false}")
    code, err = _run(tmp_path, no_imu.replace("slam: {}", "slam: {mode: camera}"), capsys)
    assert code == 0, err
    no_cam = WEARABLE.replace("head_camera: {enabled: true}", "head_camera: {enabled: false}")
    code, err = _run(tmp_path, no_cam.replace("slam: {}", "slam: {mode: inertial}"), capsys)
    assert code == 0, err


@pytest.mark.slow
def test_fig8_fusion_scores_and_head_pose(tmp_path):
    """The first 2.5 s of the jump scenario: the SLAM publishes a head pose for every IMU
    sample and frame, and stays within centimetres (measured 1.4 cm ATE, 0.12 deg heading;
    2.5 cm, 0.10 deg on 2026-11-29)."""
    from humimic.pipeline import simulation

    scenario = load_scenario(SCENARIOS_DIR / "sugiyama_fig8.yaml", duration=2.5)
    seen = []
    orig = simulation.Bus.publish

    def spy(self, topic, msg):
        if topic == "head_pose":
            seen.append(msg)
        return orig(self, topic, msg)

    simulation.Bus.publish = spy
    try:
        metrics = run_one(scenario, tmp_path, rerun="off", progress=False)
    finally:
        simulation.Bus.publish = orig
    s = metrics["slam"]
    assert s["frames"] == 75 and s["frames_without_features"] == 0
    assert s["ate_rmse_m"] < 0.04 and s["heading_rmse_deg"] < 0.25, s
    assert s["features_per_frame"] > 12
    assert len(seen) == 75 + 450  # every frame and every IMU sample (30 + 180 Hz)
    last = seen[-1].value
    assert np.all(np.isfinite(last.P)) and math.isclose(np.linalg.norm(last.q_W_I), 1.0)
    assert (tmp_path / "slam_trajectory.png").stat().st_size > 10_000
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["slam"]["ate_rmse_m"] == s["ate_rmse_m"]


@pytest.mark.slow
def test_covered_head_camera_coasts_then_recovers(tmp_path, monkeypatch):
    """A hand over the lens for 1 s in the paper's room: those frames measure nothing and are
    counted, the head pose coasts on the IMU (never NaN) and the features come back."""
    from dataclasses import replace

    from humimic.world.world import World

    capture = World.capture_headcam

    def covered(self, t):
        img = capture(self, t)
        return replace(img, image=np.zeros_like(img.image)) if 1.0 <= t < 2.0 else img

    monkeypatch.setattr(World, "capture_headcam", covered)
    scenario = load_scenario(SCENARIOS_DIR / "sugiyama_fig8.yaml", duration=3.0)
    metrics = run_one(scenario, tmp_path, rerun="off", progress=False)
    s = metrics["slam"]
    assert s["frames_without_features"] == 30  # 1 s at 30 Hz
    tr = dict(np.load(tmp_path / "slam.npz"))
    assert np.all(np.isfinite(tr["p"])) and np.all(np.isfinite(tr["P"]))
    err = np.linalg.norm(tr["p"] - tr["p_true"], axis=1)
    sd = np.sqrt(np.trace(tr["P"][:, :3, :3], axis1=1, axis2=2))
    t = tr["t"]
    # the uncertainty grew while coasting (measured 1.47x with the accelerometer's own noise,
    # 0.027 m/s^2; 3x with the paper's 0.5) while the error stayed within it (2.3 cm)
    assert sd[(t > 1.9) & (t < 2.0)].max() > 1.2 * sd[(t > 0.9) & (t < 1.0)].max()
    assert np.all(tr["measured"][t >= 2.3] > 10)  # found again
    assert err[t >= 2.5].max() < 0.06, err[t >= 2.5].max()  # measured 2.6 cm


@pytest.mark.slow
def test_fig8_jump_is_consistent_and_true_to_scale(tmp_path):
    """The whole Fig. 8 jump on seed 1: the position covariance covers the error (mean NEES
    for 3 dof measured 1.4, every frame in the 95 % band -- 16.8 and 0.18 when the
    orientation sensor's slow tilt error was fused as white noise) and the jump's height is
    not shortened (Sim(3) scale measured 0.994; 1.032 with the paper's 0.5 m/s^2
    accelerometer noise, which lagged the take-off and landing). On 2026-11-29: NEES 1.39, all
    frames in the band, scale 0.994, ATE 1.7 cm."""
    scenario = load_scenario(SCENARIOS_DIR / "sugiyama_fig8.yaml").model_copy(
        update={"seed": 1})
    s = run_one(scenario, tmp_path, rerun="off", progress=False)["slam"]
    assert s["position_nees_mean"] < 3.5, s
    assert s["position_nees_in_band_fraction"] > 0.95, s
    assert abs(s["sim3_scale"] - 1.0) < 0.015, s
    assert s["ate_rmse_m"] < 0.035, s
