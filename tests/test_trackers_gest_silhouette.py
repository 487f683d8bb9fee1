"""GEST's orientation-free silhouette offset (:mod:`humimic.perception.trackers.gest.
silhouette`) against a sphere's outline in closed form, triangulated by OpenCV."""

from __future__ import annotations

import cv2
import numpy as np
from _synth_vision import stereo_head

from humimic.perception.trackers.gest.silhouette import equivalent_radius, sphere_offset
from humimic.sensors.camera_model import invert_transform


def _outline_centre_px(cam, p_base: np.ndarray, r: float) -> np.ndarray:
    """The centre of a sphere's image ellipse in closed form: the tangent cone (half-angle
    ``asin(r / d)``) about the ray to its centre (``theta`` off the optical axis) meets the
    image plane in an ellipse whose major axis is radial, from ``tan(theta - alpha)`` to
    ``tan(theta + alpha)``; its centre is their midpoint."""
    T = invert_transform(cam.T_base_cam)
    c = T[:3, :3] @ p_base + T[:3, 3]
    d = np.linalg.norm(c)
    theta, alpha = np.arccos(c[2] / d), np.arcsin(r / d)
    rho = 0.5 * (np.tan(theta + alpha) + np.tan(theta - alpha))
    direction = c[:2] / np.linalg.norm(c[:2])
    K = cam.intrinsics
    return np.array([K.fx, K.fy]) * rho * direction + [K.cx, K.cy]


def test_sphere_offset_is_the_closed_form_outline_triangulated_by_opencv():
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    P1, P2 = (c.intrinsics.K @ invert_transform(c.T_base_cam)[:3] for c in (cam_l, cam_r))
    biggest = 0.0
    for p in ([0.6, 0.25, 1.4], [0.9, -0.3, 0.9], [1.4, 0.1, 1.2], [0.5, -0.1, 1.05]):
        p = np.array(p)
        uv_l, uv_r = (_outline_centre_px(c, p, 0.055) for c in (cam_l, cam_r))
        X = cv2.triangulatePoints(P1, P2, uv_l[:, None], uv_r[:, None])
        want = p - X[:3, 0] / X[3, 0]
        got = sphere_offset(p, 0.055, cam_l, cam_r)
        np.testing.assert_allclose(got, want, atol=1e-9)
        biggest = max(biggest, float(np.linalg.norm(want)))
    assert biggest > 5e-3                          # off the optical axis: millimetres
    assert np.isnan(sphere_offset(np.array([-1.0, 0.0, 1.0]), 0.05, cam_l, cam_r)).all()


def test_equivalent_radius_is_the_rms_semi_axis():
    assert np.isclose(equivalent_radius(np.array([0.045, 0.022, 0.08])),
                      np.sqrt((0.045 ** 2 + 0.022 ** 2 + 0.08 ** 2) / 3))
