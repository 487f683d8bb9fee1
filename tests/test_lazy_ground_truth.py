"""LazyGroundTruth against the eager compute_ground_truth (an independent evaluation of every
tick at once), over cached, dense and sparse requests and every accessor."""

from __future__ import annotations

import numpy as np
import pytest

from humimic.motion import JointTrajectory, MotionContext, compute_ground_truth, make_motion
from humimic.motion import lazy_ground_truth as lazy
from humimic.motion.config import WaveMotion
from humimic.motion.trajectory import WindowedTrajectory
from humimic.world.scene import build_scene

RATE, N = 200.0, 300


@pytest.fixture(scope="module")
def pair():
    scene = build_scene()
    ctx = MotionContext.from_scene(scene, N / RATE, np.random.default_rng(0))
    traj = JointTrajectory.from_motion(make_motion(WaveMotion(period=1.0), ctx), N / RATE)
    eager = compute_ground_truth(scene, traj, np.arange(N) / RATE)
    return eager, lazy.LazyGroundTruth.for_run(scene, traj, N, RATE)


@pytest.fixture
def small_chunks(monkeypatch):
    """Chunks of 32 ticks, two cached: requests span, miss and evict chunks."""
    monkeypatch.setattr(lazy, "CHUNK", 32)
    monkeypatch.setattr(lazy, "DENSE", 8)
    monkeypatch.setattr(lazy, "CACHED_CHUNKS", 2)


@pytest.mark.parametrize("call", [
    ("p_world", "right_hand"), ("v_base", "head"), ("a_base", "right_hand"),
    ("pose", "headcam", "W"), ("rotation", "wiimote", "base"),
    ("angular_velocity", "headcam", "site"), ("specific_force", "head_imu"),
])
def test_accessors_match_eager(pair, small_chunks, call):
    eager, gt = pair
    want = getattr(eager, call[0])(*call[1:])
    got = getattr(gt, call[0])(*call[1:])
    assert got.shape == want.shape
    rng = np.random.default_rng(1)
    for key in (7, -1, slice(None), slice(5, 290, 28), rng.integers(0, N, 40),
                np.arange(N) % 3 == 0):
        np.testing.assert_allclose(got[key], want[key], atol=1e-12)
    np.testing.assert_allclose(np.asarray(got), want, atol=1e-12)


def test_fields_sensors_and_operators(pair, small_chunks):
    eager, gt = pair
    for tick in range(0, N, 7):  # the loop's access pattern, one tick at a time
        np.testing.assert_allclose(gt.qpos[tick], eager.qpos[tick], atol=1e-12)
    np.testing.assert_allclose(gt.pos[120, 3], eager.pos[120, 3], atol=1e-12)
    np.testing.assert_allclose(gt.sensors["head_gyro"][::5], eager.sensors["head_gyro"][::5],
                               atol=1e-12)
    acc, gyro = gt.inertial("wiimote")
    np.testing.assert_allclose(acc[[3, 250]], eager.inertial("wiimote")[0][[3, 250]], atol=1e-12)
    diff = gt.p_base("right_hand") - gt.p_base("head")  # operators see whole arrays
    np.testing.assert_allclose(diff, eager.p_base("right_hand") - eager.p_base("head"),
                               atol=1e-12)
    assert gt.index_of(0.5) == eager.index_of(0.5)
    assert len(gt._cache) <= lazy.CACHED_CHUNKS
    with pytest.raises(IndexError):
        gt.p_world("head")[N]


def test_windowed_trajectory_matches_whole_run_fit():
    """Windows of 3 s with 1 s margins against one spline over 10 s: the same to rounding."""
    scene = build_scene()
    ctx = MotionContext.from_scene(scene, 10.0, np.random.default_rng(0))
    motion = make_motion(WaveMotion(period=1.3), ctx)
    whole = JointTrajectory.from_motion(motion, 10.0)
    windowed = WindowedTrajectory(motion, 10.0, window=3.0, margin=1.0)
    t = np.linspace(0.0, 10.0, 2001)
    for got, want, scale in zip(windowed.evaluate(t), whole.evaluate(t), (1.0, 10.0, 100.0),
                                strict=True):
        np.testing.assert_allclose(got, want, atol=1e-9 * scale)
