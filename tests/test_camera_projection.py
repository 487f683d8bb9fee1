"""The rendered skin-coloured head and hands appear where the ground truth projects through
the exposed intrinsics and extrinsics: within 2 px of the colour centroid at 320x240, for all
four eye cameras (each eye aimed at the target so the 24 deg foveal cameras see it too).

The foveal cameras look at a person 2 m away: at 0.9 m the hand fills ~80 px and the centroid
of an ellipsoid's perspective silhouette is 2.6 px from the projection of its centre (a true
property of perspective, measured here), which is not what this test is about."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from humimic.sensors.camera_model import Intrinsics
from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.world.gaze import pan_tilt_to
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX
from humimic.world.scene import SceneOptions, build_scene

CAMERAS = ["L_wide", "R_wide", "L_foveal", "R_foveal"]
TARGETS = ["head", "right_hand", "left_hand"]


def _raise_right_hand(scene):
    """Put the avatar's right hand in front of its chest (shoulder flexed, elbow bent)."""
    m, d = scene.model, scene.data
    for name, quat in (("r_shoulder", [np.cos(0.5), 0, -np.sin(0.5), 0]),
                       ("l_shoulder", [np.cos(0.2), np.sin(0.2), 0, 0])):
        adr = m.joint("human/" + name).qposadr[0]
        d.qpos[adr:adr + 4] = quat
    d.qpos[m.joint("human/r_elbow").qposadr[0]] = 1.2
    mujoco.mj_forward(m, d)


def _aim_eyes(scene, p_world):
    m, d = scene.model, scene.data
    for eye in ("L", "R"):
        body = m.body(f"{ROBOT_PREFIX}{eye}_eye")
        R_world_parent = d.xmat[body.parentid[0]].reshape(3, 3)
        pan, tilt = pan_tilt_to(R_world_parent.T @ (p_world - d.xpos[body.id]))
        d.qpos[scene.robot_qpos[ROBOT_JOINTS.index(f"{eye}_EP")]] = pan
        d.qpos[scene.robot_qpos[ROBOT_JOINTS.index(f"{eye}_ET")]] = tilt
    mujoco.mj_forward(m, d)


def _skin_centroid(image, skin_rgb, around, radius):
    """Centroid of skin-coloured pixels (hue/chroma close to the skin) near ``around``."""
    img = image.astype(float)
    chroma = img / np.maximum(img.sum(axis=2, keepdims=True), 1.0)
    target = np.asarray(skin_rgb) / np.sum(skin_rgb)
    mask = (np.linalg.norm(chroma - target, axis=2) < 0.03) & (img.sum(axis=2) > 60)
    v, u = np.nonzero(mask)
    near = np.hypot(u - around[0], v - around[1]) < radius
    assert near.sum() > 20, "target not visible"
    return np.array([u[near].mean(), v[near].mean()])


@pytest.fixture(scope="module")
def scenes():
    out = {}
    for distance in (1.2, 2.0):
        s = build_scene(SceneOptions(distance=distance, eye_resolution=(320, 240)))
        _raise_right_hand(s)
        out[distance] = s
    return out


@pytest.mark.parametrize("camera", CAMERAS)
@pytest.mark.parametrize("target", TARGETS)
def test_ground_truth_projects_onto_the_rendered_skin_blob(scenes, camera, target):
    scene = scenes[1.2 if "wide" in camera else 2.0]
    d = scene.data
    p_world = d.site(scene.human_site(target)).xpos.copy()
    _aim_eyes(scene, p_world)
    rig = CameraRig(scene, [CameraSpec(camera, 320, 240)], np.random.default_rng(0))
    try:
        frame = rig.capture(0.0)[camera]
    finally:
        rig.close()
    uv = frame.camera.project_world(p_world)
    # the extrinsics in the base frame agree with the world ones
    p_base = (np.linalg.inv(scene.T_world_base) @ np.append(p_world, 1.0))[:3]
    assert np.allclose(frame.camera.project_base(p_base), uv, atol=1e-9)
    assert 0 <= uv[0] < 320 and 0 <= uv[1] < 240
    radius = 25 if "wide" in camera else 70
    centroid = _skin_centroid(frame.image, scene.opts.skin, uv, radius)
    assert np.linalg.norm(centroid - uv) < 2.0, (centroid, uv)


def test_distortion_moves_points_as_opencv_predicts():
    cv2 = pytest.importorskip("cv2")
    scene = build_scene(SceneOptions(eye_resolution=(320, 240)))
    rig = CameraRig(scene, [CameraSpec("L_wide", 320, 240, k1=-0.2, k2=0.05)],
                    np.random.default_rng(0))
    try:
        frame = rig.capture(0.0)["L_wide"]
    finally:
        rig.close()
    cam = frame.camera
    p_world = scene.data.site(scene.human_site("head")).xpos.copy()
    T_cam_world = np.linalg.inv(cam.T_world_cam)
    rvec, _ = cv2.Rodrigues(T_cam_world[:3, :3])
    uv_cv, _ = cv2.projectPoints(p_world[None], rvec, T_cam_world[:3, 3],
                                 cam.intrinsics.K, cam.intrinsics.dist)
    assert np.allclose(cam.project_world(p_world), uv_cv.ravel(), atol=1e-6)
    centroid = _skin_centroid(frame.image, scene.opts.skin, uv_cv.ravel(), 25)
    assert np.linalg.norm(centroid - uv_cv.ravel()) < 2.0


def test_pixel_noise_has_the_configured_std_on_every_channel_and_is_seeded():
    from humimic.sensors.cameras import add_pixel_noise

    flat = np.full((240, 320, 3), 128, np.uint8)
    a = add_pixel_noise(flat, 4.0, np.random.default_rng(3)).astype(float) - 128
    b = add_pixel_noise(flat, 4.0, np.random.default_rng(3)).astype(float) - 128
    assert np.array_equal(a, b)
    # std of N(0, 4) rounded to integers: sqrt(16 + 1/12)
    assert a.reshape(-1, 3).std(axis=0) == pytest.approx(np.full(3, 4.01), rel=0.02)
    assert abs(a.mean()) < 0.05


@pytest.mark.parametrize("camera", ["L_wide", "R_foveal"])
def test_frustum_culling_does_not_change_the_image(camera):
    scene = build_scene(SceneOptions(eye_resolution=(320, 240)))
    _raise_right_hand(scene)
    rig = CameraRig(scene, [CameraSpec(camera, 320, 240)], np.random.default_rng(0))
    plain = mujoco.Renderer(scene.model, 240, 320)
    try:
        culled = rig.render_ideal(camera)
        plain.update_scene(scene.data, scene.camera(camera))
        assert np.array_equal(culled, plain.render())
        assert scene.model.geom_group.max() < 5  # groups restored
    finally:
        plain.close()
        rig.close()


@pytest.mark.parametrize("k1, k2", [(-0.05, 0.0), (-0.12, 0.03), (0.0, 0.0)])
def test_undistortion_inverts_projection_over_the_whole_image(k1, k2):
    """OpenCV's iterative undistortion, run to convergence: a pixel anywhere in the wide
    camera's image goes back to itself (the former 8-step fixed point left 0.003 px at
    k1 = -0.05 in the corners)."""
    import math

    from humimic.sensors.camera_model import Intrinsics, fovy_from_hfov

    intr = Intrinsics.from_fovy(fovy_from_hfov(math.radians(100), 320, 240), 320, 240, k1, k2)
    uv = np.stack(np.meshgrid(np.linspace(0, 319, 17), np.linspace(0, 239, 13)), -1)
    xy = intr.undistort_normalized(uv.reshape(-1, 2))
    back = intr.project(np.column_stack([xy, np.ones(len(xy))]))
    assert np.abs(back - uv.reshape(-1, 2)).max() < 1e-6


@pytest.mark.parametrize("k1, k2", [(-0.12, 0.03), (0.0, 0.0)])
def test_one_point_projects_like_opencv(k1, k2):
    """``Intrinsics.project`` of a single point (its scalar path) against
    ``cv2.projectPoints``; behind the camera it is NaN like a batch's rows."""
    import math

    import cv2

    from humimic.sensors.camera_model import Intrinsics, fovy_from_hfov

    intr = Intrinsics.from_fovy(fovy_from_hfov(math.radians(100), 320, 240), 320, 240, k1, k2)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-0.8, 0.8, (50, 2)), rng.uniform(0.5, 3.0, 50)])
    ref, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), intr.K, intr.dist)
    one = np.array([intr.project(p) for p in pts])
    assert np.abs(one - ref[:, 0]).max() < 1e-9
    assert np.array_equal(one, intr.project(pts))
    assert np.isnan(intr.project(np.array([0.1, 0.2, -1.0]))).all()


def test_camera_with_other_intrinsics_keeps_its_pose():
    """``CameraModel.with_intrinsics`` (GEST's crops): the pose's inverse carried over equals
    ``numpy.linalg.inv`` of the pose, and a point projects by the crop's shift."""
    import dataclasses

    from humimic.sensors.camera_model import CameraModel, Intrinsics

    c, s = np.cos(0.3), np.sin(0.3)
    T = np.array([[c, 0, s, 0.1], [0, 1, 0, -0.2], [-s, 0, c, 1.3], [0, 0, 0, 1.0]])
    cam = CameraModel("c", Intrinsics.from_fovy(np.radians(60), 320, 240), T)
    _ = cam.T_cam_base                                   # computed, then carried over
    K = cam.intrinsics
    crop = cam.with_intrinsics(dataclasses.replace(K, width=100, height=80, cx=K.cx - 40,
                                                   cy=K.cy - 30))
    assert np.abs(crop.T_cam_base - np.linalg.inv(T)).max() < 1e-12
    p = T[:3, :3] @ np.array([0.05, -0.03, 1.0]) + T[:3, 3]
    assert np.abs(cam.project_base(p) - crop.project_base(p) - (40, 30)).max() < 1e-9


def test_contains_is_the_pinhole_condition():
    """:meth:`Intrinsics.contains` of projected points against the closed form for a centred
    principal point: in front, ``|x / z| <= (W / 2) / fx`` and ``|y / z| <= (H / 2) / fy``."""
    intr = Intrinsics.from_fovy(np.radians(75.0), 320, 240)
    p = np.random.default_rng(1).uniform([-3, -3, -1], [3, 3, 4], (2000, 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = ((p[:, 2] > 0) & (np.abs(p[:, 0] / p[:, 2]) <= 160.0 / intr.fx)
                    & (np.abs(p[:, 1] / p[:, 2]) <= 120.0 / intr.fy))
    np.testing.assert_array_equal(intr.contains(intr.project(p)), expected)
    assert 0.1 < expected.mean() < 0.9  # both kinds drawn
    assert not intr.contains(np.array([np.nan, np.nan]))
