"""Kinematic flips of an arm (``kpf/flips.py``) against independent geometry: every flip keeps
the elbow's and wrist's camera rays (same images, checked by projecting with the camera
model's own ``project``), the bone lengths and the shoulder; the flipped joints are the other
intersections of the rays with the bones' spheres (closed form); flipping twice returns the
pose; the scores' ray split of an error is Pythagorean and matches the camera frame's split
on the optical axis."""

from __future__ import annotations

import numpy as np

from humimic.perception.trackers.kpf.flips import FLIPS, arm_flips, flip_free_error
from humimic.perception.trackers.kpf.scores import camera_centres, ray_split
from humimic.perception.trackers.kpf.tracker import kpf_body


def _camera(x: float = 2.0, y: float = 0.1) -> np.ndarray:
    """T_cam_base of a camera at (x, y, 1.3) looking back along -x (OpenCV axes)."""
    R_base_cam = np.column_stack([[0, 1, 0], [0, 0, -1], [-1, 0, 0]]).astype(float)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_base_cam.T, -R_base_cam.T @ np.array([x, y, 1.3])
    return T


def _poses(n: int, seed: int = 3) -> np.ndarray:
    body = kpf_body()
    rng = np.random.default_rng(seed)
    q = np.zeros((n, 14))
    q[:, 2] = 1.1
    q[:, 6:10] = rng.uniform([-0.3, 0.1, -0.8, 0.3], [1.4, 1.4, 0.8, 1.5], (n, 4))
    q[:, 10:14] = rng.uniform([-0.3, 0.1, -0.8, 0.3], [1.4, 1.4, 0.8, 1.5], (n, 4))
    return body.free_limits.clamp(q)


def test_flips_keep_the_joint_images_and_bone_lengths():
    body = kpf_body()
    q = _poses(300)
    T = _camera()
    c = camera_centres(T[None])[0]
    np.testing.assert_allclose(c, [2.0, 0.1, 1.3], atol=1e-12)
    a = body.forward(q)
    S, E, W = (a.joint(f"r_{j}") for j in ("shoulder", "elbow", "wrist"))
    got = arm_flips(body, q, "R", c)
    for name in FLIPS:
        ok = np.all(np.isfinite(got[name]), axis=1)
        assert ok.mean() > 0.5, name                    # the wrist flip always exists
        b = body.forward(got[name][ok])
        S2, E2, W2 = (b.joint(f"r_{j}") for j in ("shoulder", "elbow", "wrist"))
        np.testing.assert_allclose(S2, S[ok], atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(E2 - S2, axis=1), body.skeleton.upper_arm)
        np.testing.assert_allclose(np.linalg.norm(W2 - E2, axis=1), body.skeleton.forearm)
        for P, P2 in ((E[ok], E2), (W[ok], W2)):        # on the same camera rays
            u, u2 = P - c, P2 - c
            cos = np.sum(u * u2, 1) / np.linalg.norm(u, axis=1) / np.linalg.norm(u2, axis=1)
            assert np.all(cos > 1 - 1e-9), name
        np.testing.assert_array_equal(got[name][ok][:, 10:], q[ok][:, 10:])
    # the wrist flip is the second root of |c + t u - E| = forearm (quadratic in t, numpy)
    u = (W - c) / np.linalg.norm(W - c, axis=1, keepdims=True)
    W2 = body.forward(got["wrist"]).joint("r_wrist")
    for k in range(0, 300, 37):
        oc = c - E[k]
        roots = np.roots([1.0, 2 * u[k] @ oc, oc @ oc - body.skeleton.forearm ** 2]).real
        t, r0 = np.linalg.norm(W2[k] - c), np.linalg.norm(W[k] - c)
        # measured <= 2.5e-14 m for both roots (2026-11-29; the bound was 1e-9)
        assert np.min(np.abs(roots - t)) < 1e-12 and np.min(np.abs(roots - r0)) < 1e-12
        assert abs(t - r0) > 0.03                       # the other root: measured >= 76 mm


def test_flipping_twice_returns_the_pose_and_forgives_the_flip():
    body = kpf_body()
    q = _poses(100, seed=5)
    c = np.array([2.0, 0.1, 1.3])
    once = arm_flips(body, q, "R", c)["wrist"]
    twice = arm_flips(body, once, "R", c)["wrist"]
    np.testing.assert_allclose(body.forward(twice).joint("r_wrist"),
                               body.forward(q).joint("r_wrist"), atol=1e-12)  # measured 1.7e-15
    err = flip_free_error(body, once, q, "R", c)
    assert np.max(err) < 1e-12                          # measured 2.1e-15 (was 1e-9)
    moved = np.linalg.norm(body.forward(once).joint("r_wrist")
                           - body.forward(q).joint("r_wrist"), axis=1)
    assert np.median(moved) > 0.1                       # a flip moves the wrist (0.24 m)


def test_ray_split_is_pythagorean_and_on_axis_is_the_camera_z():
    rng = np.random.default_rng(0)
    T = np.repeat(_camera()[None], 50, axis=0)
    p = np.array([0.0, 0.1, 1.3]) + rng.normal(0, 0.3, (50, 3))
    d = rng.normal(0, 0.1, (50, 3))
    depth, lateral = ray_split(d, p, T)
    np.testing.assert_allclose(depth ** 2 + lateral ** 2, np.sum(d * d, axis=1))
    on_axis = np.array([[0.0, 0.1, 1.3]] * 50)        # on the optical axis: camera z is depth
    depth, lateral = ray_split(d, on_axis, T)
    d_cam = d @ T[0, :3, :3].T
    np.testing.assert_allclose(depth, np.abs(d_cam[:, 2]), atol=1e-12)
    np.testing.assert_allclose(lateral, np.linalg.norm(d_cam[:, :2], axis=1), atol=1e-12)


def test_tracker_flip_jumps_replace_a_share_with_same_image_poses():
    """``flip_share``: about that share of the particles per arm get one of their flips (within
    the joint limits): arms changed in 3-D, their elbow and wrist pixels unchanged (the camera
    model's projection), everything else untouched."""
    from humimic.perception.trackers.kpf.flips import flip_jumps
    from humimic.sensors.camera_model import Intrinsics

    body = kpf_body()
    intr = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)
    T = _camera()
    q = _poses(2000, seed=7)
    q[:, 3] = np.pi                                     # facing the camera
    out = flip_jumps(body, q.copy(), T, 0.2, body.free_limits, np.random.default_rng(1))
    assert np.all(body.free_limits.inside(out))
    np.testing.assert_array_equal(out[:, :6], q[:, :6])
    a, b = body.forward(q), body.forward(out)
    for side, arm in (("r", slice(6, 10)), ("l", slice(10, 14))):
        changed = np.any(out[:, arm] != q[:, arm], axis=1)
        assert 0.05 < changed.mean() < 0.2, changed.mean()
        moved = np.linalg.norm(b.joint(f"{side}_wrist") - a.joint(f"{side}_wrist"), axis=1)
        assert np.median(moved[changed]) > 0.15         # measured 0.42, 0.46 m (was 0.01)
        for j in ("elbow", "wrist"):                   # the same pixels
            np.testing.assert_allclose(intr.project(b.to(T).joint(f"{side}_{j}")[changed]),
                                       intr.project(a.to(T).joint(f"{side}_{j}")[changed]),
                                       atol=1e-6)
