"""Gaze law and camera-frame geometry, checked with MuJoCo's kinematics and the camera model."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.control.gaze import Gaze, camera_frame_point, eye_angles, rate_limit
from humimic.control.oracle import in_image, noisy_state, oracle_covariance
from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX
from humimic.world.scene import build_scene


@pytest.fixture(scope="module")
def scene():
    return build_scene()


def _set_eyes(scene, angles):
    d = scene.data
    for name, a in zip(("L_EP", "L_ET", "R_EP", "R_ET"), angles, strict=True):
        d.qpos[scene.robot_qpos[ROBOT_JOINTS.index(name)]] = a
    mujoco.mj_forward(scene.model, d)  # cameras are placed by mj_camlight


def test_eye_angles_point_both_cameras_at_the_target(scene):
    m, d = scene.model, scene.data
    mujoco.mj_kinematics(m, d)
    rng = np.random.default_rng(0)
    eye_c = d.site(ROBOT_PREFIX + "eye_center").xpos.copy()
    for _ in range(5):
        target = eye_c + np.array([1.2, 0, 0]) + rng.uniform(-0.4, 0.4, 3)
        angles = []
        for eye in ("L", "R"):
            body = m.body(f"{ROBOT_PREFIX}{eye}_eye")
            R_parent = d.xmat[body.parentid[0]].reshape(3, 3)
            angles += eye_angles(target, d.xpos[body.id], R_parent)
        _set_eyes(scene, angles)
        for cam in ("L_wide", "R_wide", "L_foveal", "R_foveal"):
            c = scene.camera(cam)
            axis = -d.cam_xmat[c].reshape(3, 3)[:, 2]  # MuJoCo cameras look along -z
            to_target = target - d.cam_xpos[c]
            cos = axis @ to_target / np.linalg.norm(to_target)
            assert np.degrees(np.arccos(min(cos, 1.0))) < 1e-6


def test_camera_frame_point_projects_like_the_camera_model(scene):
    rig = CameraRig(scene, [CameraSpec("L_wide", 320, 240)], np.random.default_rng(0))
    _set_eyes(scene, [0.2, -0.1, 0.15, -0.1])
    p = np.array([1.4, 0.2, 1.5])
    model = rig.camera_model("L_wide")
    uv = rig.intrinsics("L_wide").project(camera_frame_point(scene.data, scene.camera("L_wide"),
                                                             p))
    np.testing.assert_allclose(uv, model.project_world(p), atol=1e-9)
    rig.close()


def test_gaze_reaches_the_target_within_the_speed_limit(scene):
    _set_eyes(scene, [0.0, 0.0, 0.0, 0.0])
    gaze = Gaze(scene, max_speed=5.0, dt=1 / 420)
    eye_c = scene.data.site(ROBOT_PREFIX + "eye_center").xpos
    target = eye_c + np.array([1.0, 0.4, -0.2])
    for _ in range(200):
        q, qdot = gaze.step(target)
        assert np.all(np.abs(qdot) <= 5.0 + 1e-9)
    _set_eyes(scene, q)
    c = scene.camera("L_wide")
    axis = -scene.data.cam_xmat[c].reshape(3, 3)[:, 2]
    to_target = target - scene.data.cam_xpos[c]
    assert axis @ to_target / np.linalg.norm(to_target) > np.cos(np.radians(0.01))


def test_rate_limit():
    np.testing.assert_allclose(rate_limit(np.zeros(3), np.array([1.0, -0.05, -1.0]), 0.1),
                               [0.1, -0.05, -0.1])


def test_in_image():
    from humimic.sensors.camera_model import Intrinsics

    intr = Intrinsics(320, 240, 134.0, 134.0, 159.5, 119.5)
    assert in_image(np.array([0.0, 0.0, 1.0]), intr)
    assert not in_image(np.array([0.0, 0.0, -1.0]), intr)
    assert not in_image(np.array([1.3, 0.0, 1.0]), intr)  # u = 159.5 + 174 > 319.5
    assert in_image(np.array([1.15, 0.0, 1.0]), intr)


def test_oracle_noise_has_the_requested_spread():
    rng = np.random.default_rng(7)
    zero = np.zeros(3)
    draws = np.array([np.concatenate(noisy_state(zero, zero, zero, (0.01, 0.1, 1.0), rng))
                      for _ in range(4000)])
    np.testing.assert_allclose(draws.std(axis=0), np.repeat([0.01, 0.1, 1.0], 3), rtol=0.06)
    assert oracle_covariance((0.0, 0.0, 0.0)) is None
    np.testing.assert_allclose(np.diag(oracle_covariance((0.01, 0.1, 1.0))),
                               np.repeat([1e-4, 1e-2, 1.0], 3))


def test_gaze_on_a_trackers_pose_takes_the_midpoint_with_a_second_target():
    """``gaze.midpoint_with`` (the kpf's foveal view of the forearm): the gaze target from a
    tracker's pose is the mean of the two joints; without it the target's joint; another
    tracker's pose or one not tracking is ignored; it needs ``gaze.tracker``."""
    from types import SimpleNamespace

    from humimic.control.config import GazeConfig
    from humimic.control.stage import MimicStage
    from humimic.messages import PoseEstimate
    from humimic.stamped import Stamped

    joints = {"r_elbow": np.array([0.1, 0.2, 0.3]), "r_wrist": np.array([0.5, -0.2, 0.1])}
    est = PoseEstimate("kpf", "kpf", np.zeros(14), tuple(f"q{i}" for i in range(14)),
                       joints=joints)
    for mid, want in ((None, joints["r_elbow"]), ("right_wrist", [0.3, 0.0, 0.2])):
        g = GazeConfig(enabled=True, target="right_elbow", tracker="kpf", midpoint_with=mid)
        stage = SimpleNamespace(cfg=SimpleNamespace(gaze=g), gaze_latest=None)
        MimicStage._on_pose(stage, "poses", Stamped(0.5, est, 0.6))
        t, target, t_ready = stage.gaze_latest
        assert (t, t_ready) == (0.5, 0.6) and np.allclose(target.p_base, want)
        for other in (PoseEstimate("gest", "gest", est.state, est.state_names, joints=joints),
                      PoseEstimate("kpf", "kpf", est.state, est.state_names, joints=joints,
                                   status="lost")):
            stage.gaze_latest = None
            MimicStage._on_pose(stage, "poses", Stamped(0.7, other, 0.8))
            assert stage.gaze_latest is None
    with pytest.raises(ValueError, match="tracker"):
        GazeConfig(midpoint_with="right_wrist")
