"""The wearable room as the head camera sees it: enough corners for a feature tracker along the
paper's Table II path, the screen's corners (the prior known features) where the ground truth
projects them through the exposed camera model, and the Wii remote's red marker (hue 0-20 deg)
where and as large as its known size says."""

from __future__ import annotations

import cv2
import mujoco
import numpy as np
import pytest

from humimic.motion import quat
from humimic.motion.avatar import QPOS_SLICES
from humimic.paths import SCENARIOS_DIR
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.world.frames import R_CV_I, SCREEN_CORNERS_W, from_frame
from humimic.world.wearable_probe import count_corners
from humimic.world.world import World

TABLE_II_XZ = [(1.25, -2.5), (1.25, 0.0), (0.0, -2.5), (-1.25, 0.0)]


@pytest.fixture(scope="module")
def walk():
    world = World(load_scenario(SCENARIOS_DIR / "wearable_walk.yaml"), Rngs(0))
    yield world
    world.close()


def _frame(world, t):
    k = int(round(t * world.clock.physics_rate))
    world.apply_human(k)
    mujoco.mj_forward(world.scene.model, world.scene.data)
    return k, world.capture_headcam(t)


def _project(world, k, p_world):
    """Pixels of world points through the head camera's intrinsics at its true pose."""
    T = world.gt.pose("headcam")[k]
    p_I = (np.asarray(p_world) - T[:3, 3]) @ T[:3, :3]
    return world.head_rig.intrinsics("headcam").project(p_I @ R_CV_I.T)


def test_at_least_40_corners_in_view_all_along_the_table_ii_walk(walk):
    """Every 0.5 s of the scenario (walking, standing, looking around, arm raised): measured
    minimum ~105 corners (OpenCV goodFeaturesToTrack, humimic.world.wearable_probe)."""
    counts = [count_corners(_frame(walk, t)[1].image)
              for t in np.arange(0.0, walk.scenario.duration, 0.5)]
    assert min(counts) >= 40, counts
    assert np.mean(counts) > 100


@pytest.mark.parametrize("xz", TABLE_II_XZ)
def test_at_least_40_corners_at_each_table_ii_position_turned_either_way(walk, xz):
    """Standing at a Table II position, facing the screen or turned 45 deg to either side
    (measured minimum ~115)."""
    s = walk.scene
    ctx_xy, _ = walk_ctx_xy(walk, xz)
    for heading in (-45.0, 0.0, 45.0):
        q = s.human_qpos0.copy()
        q[0:2] = ctx_xy
        q[QPOS_SLICES["root_rot"]] = quat.from_rotvec(np.array([0, 0, np.radians(heading)]))
        s.data.qpos[s.human_qpos] = q
        mujoco.mj_forward(s.model, s.data)
        n = count_corners(walk.capture_headcam(0.0).image)
        assert n >= 40, (xz, heading, n)


def walk_ctx_xy(world, xz):
    from humimic.motion import MotionContext

    ctx = MotionContext.from_scene(world.scene, 1.0, np.random.default_rng(0))
    return ctx.W_to_avatar(np.array(xz, float))


def test_screen_corners_are_sharp_corners_where_they_project(walk):
    k, frame = _frame(walk, 0.0)  # at the start, 4.5 m from the screen
    uv = _project(walk, k, from_frame(walk.T_world_W, SCREEN_CORNERS_W))
    grey = cv2.cvtColor(frame.image, cv2.COLOR_RGB2GRAY)
    found = cv2.goodFeaturesToTrack(grey, 500, 0.01, 5).reshape(-1, 2)
    found = cv2.cornerSubPix(grey, found.astype(np.float32), (3, 3), (-1, -1),
                             (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    for p in uv:  # measured 0.15-0.25 px (2026-11-29; the bound was 1 px)
        assert np.min(np.linalg.norm(found - p, axis=1)) < 0.6, p


def test_wii_marker_is_red_and_as_large_as_its_size_says(walk):
    """Arm stretched forward, head pitched down (t = 11.8 s): the paper's marker extraction
    (hue 0-20 deg, largest region) finds it at its projected centre, with the area of a
    sphere of radius 0.02 m at that depth (pi (f r / Z)^2, within its pixel noise)."""
    k, frame = _frame(walk, 11.8)
    hsv = cv2.cvtColor(frame.image, cv2.COLOR_RGB2HSV)  # OpenCV hue: degrees / 2
    mask = ((hsv[..., 0] <= 10) & (hsv[..., 1] > 120) & (hsv[..., 2] > 80)).astype(np.uint8)
    n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask)
    assert n > 1, "no red region"
    big = 1 + np.argmax(stats[1:, cv2.CC_STAT_AREA])
    p_marker = walk.gt.p_world("wiimote_marker")[k]
    uv = _project(walk, k, p_marker)
    assert np.linalg.norm(centroids[big] - uv) < 0.4  # measured 0.13 px (was 1.5)
    T = walk.gt.pose("headcam")[k]
    depth = (p_marker - T[:3, 3]) @ T[:3, 2]
    f = walk.head_rig.intrinsics("headcam").fx
    radius = walk.scene.model.geom("human/wiimote_marker").size[0]
    expected = np.pi * (f * radius / depth) ** 2
    assert stats[big, cv2.CC_STAT_AREA] == pytest.approx(expected, rel=0.25)
