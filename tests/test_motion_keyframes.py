"""Keyframes (interpolation, IK targets, joints) and config validation of every motion kind."""

from __future__ import annotations

import numpy as np
import pytest
from _kinematics import site_positions
from pydantic import TypeAdapter, ValidationError
from scipy.spatial.transform import Rotation

from humimic.motion import MotionConfig, MotionContext, make_motion
from humimic.motion.avatar import QPOS_SLICES, load_avatar_model

EXACT_M = 1e-9  # m: the keys are met up to rounding (measured <= 4e-16 m; was 1 mm)
ADAPTER = TypeAdapter(MotionConfig)

KEYS = [
    {"t": 0.5, "right_hand": [0.30, -0.20, 1.20]},
    {"t": 1.5, "right_hand": [0.35, -0.40, 1.45], "head": [0.05, 0.10, 1.60]},
    {"t": 3.0, "right_hand": [0.25, -0.10, 1.35], "head": [0.00, -0.05, 1.64],
     "joints": {"l_elbow": 1.2}},
    {"t": 4.0, "joints": {"l_elbow": 0.3}},
]


def _sites(qpos, names):
    return site_positions(load_avatar_model(), qpos, names)


def _motion(frames, **kw):
    cfg = ADAPTER.validate_python({"kind": "keyframes", "frames": frames, **kw})
    return make_motion(cfg, MotionContext.facing_robot())


@pytest.mark.parametrize("interpolation", ["spline", "min_jerk"])
def test_keys_are_reached(interpolation):
    motion = _motion(KEYS, interpolation=interpolation)
    t_keys = np.array([k["t"] for k in KEYS])
    q = motion.sample(t_keys)
    s = _sites(q, ["r_hand", "head"])
    np.testing.assert_allclose(s["r_hand"][:3], [k["right_hand"] for k in KEYS[:3]], atol=EXACT_M)
    np.testing.assert_allclose(s["head"][1:3], [k["head"] for k in KEYS[1:3]], atol=EXACT_M)
    np.testing.assert_allclose(q[2:, QPOS_SLICES["l_elbow"].start], [1.2, 0.3], atol=1e-12)
    # before its first key / after its last key a channel holds
    s2 = _sites(motion.sample(np.array([0.0, 3.5, 9.0])), ["r_hand", "head"])
    np.testing.assert_allclose(s2["r_hand"][0], KEYS[0]["right_hand"], atol=EXACT_M)
    np.testing.assert_allclose(s2["r_hand"][1:], [KEYS[2]["right_hand"]] * 2, atol=EXACT_M)
    np.testing.assert_allclose(s2["head"][0], KEYS[1]["head"], atol=EXACT_M)


@pytest.mark.parametrize("interpolation, stops_inside", [("spline", False), ("min_jerk", True)])
def test_rest_at_keys(interpolation, stops_inside):
    """Spline: at rest at the first and last key only; minimum jerk: at rest at every key."""
    motion = _motion(KEYS[:3], interpolation=interpolation)
    h = 1e-4

    def speed(t):
        p = _sites(motion.sample(np.array([t - h, t + h])), ["r_hand"])["r_hand"]
        return np.linalg.norm(p[1] - p[0]) / (2 * h)

    assert speed(0.5) < 1.2e-4 and speed(3.0) < 1.2e-4  # measured <= 4e-5 m/s (was 1e-3)
    assert (speed(1.5) < 1e-3) == stops_inside
    assert speed(1.0) > 0.05


def test_ball_joint_rotation_vectors():
    rv = [0.1, -0.2, 0.3]
    q = _motion([{"t": 0.0, "joints": {"spine": rv, "root_x": 0.2}}]).sample(np.array([1.0]))
    spine = q[0, QPOS_SLICES["spine"]]
    expected = np.roll(Rotation.from_rotvec(rv).as_quat(), 1)
    assert abs(np.dot(spine, expected)) == pytest.approx(1.0, abs=1e-12)
    assert q[0, 0] == pytest.approx(0.2)


@pytest.mark.parametrize(
    "frames, message",
    [
        ([{"t": 1.0}, {"t": 1.0}], "frame times must increase"),
        ([{"t": 0.0, "joints": {"r_elbw": 1.0}}], "unknown joint 'r_elbw'"),
        ([{"t": 0.0, "joints": {"spine": 0.5}}], "spine is a ball joint"),
        ([{"t": 0.0, "joints": {"r_elbow": [0, 1, 0]}}], "r_elbow is a hinge joint"),
        ([{"t": 0.0, "head": [0, 0, 1.6]}, {"t": 1.0, "joints": {"root_x": 0.1}}],
         "head targets drive root_x"),
        ([{"t": 0.0, "right_hand": [0.3, -0.2, 1.2], "joints": {"r_elbow": 1.0}}],
         "right_hand targets drive r_elbow"),
        ([{"t": 0.0, "rigth_hand": [0.3, -0.2, 1.2]}], "Extra inputs are not permitted"),
        ([{"t": -1.0}], "greater than or equal to 0"),
        ([], "at least 1 item"),
    ],
)
def test_keyframe_validation(frames, message):
    with pytest.raises(ValidationError, match=message):
        ADAPTER.validate_python({"kind": "keyframes", "frames": frames})


@pytest.mark.parametrize("kind", ["static", "wave", "axes", "point", "head_sweep", "figure8"])
def test_every_kind_has_working_defaults(kind):
    cfg = ADAPTER.validate_python({"kind": kind})
    motion = make_motion(cfg, MotionContext.facing_robot())
    t = np.linspace(0.0, 10.0, 200)
    q = motion.sample(t)
    assert q.shape == (200, 51) and np.all(np.isfinite(q))
    assert motion.diagnostics(t) == {}  # reachable and inside every joint range


@pytest.mark.parametrize(
    "data, message",
    [
        ({"kind": "wave", "amplitude": 0.0}, "greater than 0"),
        ({"kind": "wave", "amplitude": 0.4}, "must be smaller than arc_radius"),
        ({"kind": "wave", "hand": "both"}, "'right' or 'left'"),
        ({"kind": "axes", "order": ["x", "w"]}, "'x', 'y' or 'z'"),
        ({"kind": "point", "gestures": []}, "at least 1 item"),
        ({"kind": "static", "tremor": -0.001}, "greater than or equal to 0"),
        ({"kind": "head_sweep", "lean": 1.5}, "less than or equal to 1"),
        ({"kind": "bvh", "file": "x.bvh", "speed": 0.0}, "greater than 0"),
        ({"kind": "bvh"}, "Field required"),
        ({"kind": "dance"}, "does not match any of the expected tags"),
        ({"kind": "wave", "amplitud": 0.3}, "Extra inputs are not permitted"),
    ],
)
def test_config_range_checks(data, message):
    with pytest.raises(ValidationError, match=message):
        ADAPTER.validate_python(data)
