"""The wearable frames (Sugiyama & Miura): W from the room's screen, the head camera's frame I
and the Wii remote's frame A, and ground truth in them against independent computations."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.motion import JointTrajectory, MotionContext, compute_ground_truth, make_motion
from humimic.motion.config import HeadSweepMotion
from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.world.frames import (
    R_CV_I,
    SCREEN_CORNERS_W,
    from_frame,
    paper_frame,
    to_frame,
)
from humimic.world.scene import SceneOptions, build_scene


@pytest.fixture(scope="module")
def scene():
    return build_scene(SceneOptions(show_wiimote=True))


@pytest.fixture(scope="module")
def sweep(scene):
    ctx = MotionContext.from_scene(scene, 2.0, np.random.default_rng(0))
    traj = JointTrajectory.from_motion(make_motion(HeadSweepMotion(period=1.0), ctx), 2.0)
    t = np.linspace(0.3, 1.7, 15)
    return traj, t, compute_ground_truth(scene, traj, t)


def test_paper_frame_from_a_screen_pose():
    R = Rotation.from_euler("z", 30, degrees=True).as_matrix() @ np.array(
        [[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # W axes: z horizontal, y up
    T = paper_frame(R, [4.0, 1.0, 1.5])
    # the origin is 2 m in front of the screen, level with its centre; z points at it
    np.testing.assert_allclose(from_frame(T, [0, 0, 2.0]), [4.0, 1.0, 1.5], atol=1e-12)
    assert T[2, 3] == pytest.approx(1.5)
    np.testing.assert_allclose(to_frame(T, from_frame(T, SCREEN_CORNERS_W)), SCREEN_CORNERS_W,
                               atol=1e-12)


def test_room_screen_corners_are_the_papers_in_W(scene):
    d = scene.data
    names = ("screen_tl", "screen_tr", "screen_br", "screen_bl")  # the paper's order
    p_W = to_frame(scene.T_world_W, np.array([d.site(n).xpos for n in names]))
    np.testing.assert_allclose(p_W, SCREEN_CORNERS_W, atol=1e-9)
    assert scene.T_world_W[:3, 1] == pytest.approx([0, 0, 1])  # W's y is up
    assert scene.T_world_W[2, 3] == pytest.approx(1.5)  # level with the screen centre


def test_pose_in_W_matches_forward_kinematics(scene, sweep):
    traj, t, gt = sweep
    m, d = scene.model, mujoco.MjData(scene.model)
    T_W_world = np.linalg.inv(scene.T_world_W)
    for k, q in enumerate(traj.qpos(t)):
        d.qpos[scene.human_qpos] = q
        mujoco.mj_kinematics(m, d)
        for name, site in (("headcam", "human/headcam"), ("wiimote", "human/wiimote_imu")):
            T = np.eye(4)
            T[:3, :3] = d.site(site).xmat.reshape(3, 3)
            T[:3, 3] = d.site(site).xpos
            np.testing.assert_allclose(gt.pose(name, "W")[k], T_W_world @ T, atol=1e-12)
            np.testing.assert_allclose(gt.pose(name)[k], T, atol=1e-12)


def test_gyro_and_accelerometer_from_the_site_kinematics(scene, sweep):
    _, _, gt = sweep
    np.testing.assert_allclose(gt.angular_velocity("head_imu", "site"),
                               gt.sensor("head_gyro"), atol=1e-9)
    np.testing.assert_allclose(gt.angular_velocity("wiimote", "site"),
                               gt.sensor("wiimote_gyro"), atol=1e-9)
    np.testing.assert_allclose(gt.specific_force("head_imu"), gt.sensor("head_acc"), atol=1e-9)
    np.testing.assert_allclose(gt.specific_force("wiimote"), gt.sensor("wiimote_acc"),
                               atol=1e-9)
    # frame changes are rotations of the same vectors
    w_W = gt.angular_velocity("headcam", "W")
    np.testing.assert_allclose(np.linalg.norm(w_W, axis=1),
                               np.linalg.norm(gt.angular_velocity("headcam"), axis=1))
    v_W = gt.velocity("headcam", "W")
    np.testing.assert_allclose(v_W, gt.v_world("headcam") @ scene.T_world_W[:3, :3])


def test_head_imu_shares_the_camera_frame_I(scene, sweep):
    _, _, gt = sweep
    np.testing.assert_allclose(gt.pose("head_imu"), gt.pose("headcam"), atol=1e-12)


def test_camera_model_pose_is_frame_I_in_opencv_axes(scene):
    d = scene.data
    mujoco.mj_forward(scene.model, d)
    rig = CameraRig(scene, [CameraSpec("headcam", 368, 240)], np.random.default_rng(0))
    try:
        T_world_cv = rig.camera_model("headcam").T_world_cam
    finally:
        rig.close()
    R_world_I = d.site("human/headcam").xmat.reshape(3, 3)
    np.testing.assert_allclose(T_world_cv[:3, :3], R_world_I @ R_CV_I.T, atol=1e-9)
    np.testing.assert_allclose(T_world_cv[:3, 3], d.site("human/headcam").xpos, atol=1e-9)


def test_standing_person_facing_the_screen_has_level_axes(scene):
    """In the default lab room the person faces the robot (+x world is towards them) and the
    screen is behind the robot: the person faces the screen, so R_W_I is the identity."""
    d = scene.data
    mujoco.mj_forward(scene.model, d)
    R_world_I = d.site("human/headcam").xmat.reshape(3, 3)
    np.testing.assert_allclose(scene.T_world_W[:3, :3].T @ R_world_I, np.eye(3), atol=1e-9)
    # the Wii remote in the hanging right hand points down, buttons forward (frame A)
    R_W_A = scene.T_world_W[:3, :3].T @ d.site("human/wiimote_imu").xmat.reshape(3, 3)
    np.testing.assert_allclose(R_W_A[:, 2], [0, -1, 0], atol=1e-9)
    np.testing.assert_allclose(R_W_A[:, 1], [0, 0, 1], atol=1e-9)
