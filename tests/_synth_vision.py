"""Synthetic scenes for the vision tests: a stereo head and a textured plane; blob image streams."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from humimic.sensors.camera_model import CameraModel, Intrinsics, make_transform

#: OpenCV camera axes expressed in a base frame with x forward, y left, z up.
R_BASE_CVCAM = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])

SKIN_RGB = (224, 172, 140)


def stereo_head(pan_l=0.03, pan_r=-0.04, tilt_l=0.05, tilt_r=0.02, roll_r=0.01,
                k1=-0.05, k2=0.01, width=320, height=240, hfov_deg=60.0, baseline=0.066,
                p_head=(0.0, 0.0, 1.2)):
    """Two eye cameras with independent pan/tilt (not rectified), radial distortion."""
    f = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
    intr = Intrinsics(width, height, f, f, (width - 1) / 2, (height - 1) / 2, k1, k2)
    cams = []
    for name, dy, pan, tilt, roll in (("left", baseline / 2, pan_l, tilt_l, 0.0),
                                      ("right", -baseline / 2, pan_r, tilt_r, roll_r)):
        R_eye = Rotation.from_euler("zyx", [pan, tilt, roll]).as_matrix()  # base-frame pan/tilt
        T = make_transform(R_eye @ R_BASE_CVCAM, np.array(p_head) + np.array([0.0, dy, 0.0]))
        cams.append(CameraModel(name, intr, T))
    return cams[0], cams[1]


class TexturedPlane:
    """A plane ``X = O + s e1 + t e2`` (metres) carrying a smooth random colour texture."""

    def __init__(self, rng, origin, e1, e2, size_m=0.6, tex_px=600):
        self.O, self.e1, self.e2 = (np.asarray(v, float) for v in (origin, e1, e2))
        self.n = np.cross(self.e1, self.e2)
        self.scale = size_m / tex_px  # metres per texture pixel
        self.size_m = size_m
        noise = rng.integers(0, 256, (tex_px, tex_px, 3)).astype(np.float32)
        tex = cv2.GaussianBlur(noise, (0, 0), 2.0)
        tex = (tex - tex.mean()) * 3.0 + 128
        self.texture = np.clip(tex, 0, 255).astype(np.uint8)

    def ray_hit(self, c, d):
        """Intersections of rays ``c + z d`` (d: (..., 3)) with the plane: points (..., 3)."""
        z = ((self.O - c) @ self.n) / (d @ self.n)
        return c + z[..., None] * d

    def render(self, cam: CameraModel) -> np.ndarray:
        intr = cam.intrinsics
        vv, uu = np.mgrid[0:intr.height, 0:intr.width].astype(float)
        xn = intr.undistort_normalized(np.stack([uu, vv], -1))
        d = np.concatenate([xn, np.ones(xn.shape[:-1] + (1,))], -1) @ cam.T_base_cam[:3, :3].T
        X = self.ray_hit(cam.T_base_cam[:3, 3], d) - self.O
        s = (X @ self.e1) / self.scale + self.size_m / (2 * self.scale)
        t = (X @ self.e2) / self.scale + self.size_m / (2 * self.scale)
        return cv2.remap(self.texture, s.astype(np.float32), t.astype(np.float32),
                         cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def point_on_plane_seen_at(plane: TexturedPlane, cam: CameraModel, uv) -> np.ndarray:
    xn = cam.intrinsics.undistort_normalized(np.asarray(uv, float))
    d = cam.T_base_cam[:3, :3] @ np.array([xn[0], xn[1], 1.0])
    return plane.ray_hit(cam.T_base_cam[:3, 3], d)


def clutter_background(rng, height=240, width=320) -> np.ndarray:
    """Seeded cluttered background: random non-skin rectangles and noise."""
    img = np.full((height, width, 3), 60, np.uint8)
    for _ in range(40):
        x0, y0 = rng.integers(0, width), rng.integers(0, height)
        w, h = rng.integers(5, 60), rng.integers(5, 60)
        colour = tuple(int(c) for c in rng.choice([30, 80, 120, 200], 3))
        if colour[0] > colour[1] + 20 and colour[1] > colour[2]:  # keep clutter non-skin
            colour = (colour[2], colour[1], colour[0])
        cv2.rectangle(img, (int(x0), int(y0)), (int(x0 + w), int(y0 + h)), colour, -1)
    return img


def draw_ellipse(img, centre, axes, angle_deg, colour=SKIN_RGB):
    """Anti-aliased filled ellipse with sub-pixel centre (cv2 shift=4: 1/16 px)."""
    c = (int(round(centre[0] * 16)), int(round(centre[1] * 16)))
    ax = (int(round(axes[0] * 16)), int(round(axes[1] * 16)))
    cv2.ellipse(img, c, ax, angle_deg, 0, 360, colour, -1, cv2.LINE_AA, shift=4)
    return img


def add_noise(img, rng, sigma=4.0):
    return np.clip(img + rng.normal(0, sigma, img.shape), 0, 255).astype(np.uint8)
