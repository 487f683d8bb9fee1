"""A textured wall for image-level tests of the SLAM front end, rendered by ray casting.

The wall is the plane ``z = 2`` of the paper's frame W (the screen wall), 6 x 3 m, covered
with natural photographs (scikit-image's sample images) and a black screen whose corners are
:data:`_synth_slam.SCREEN`. A frame is rendered through a distorted camera by casting each
pixel's ray (undistorted with :mod:`humimic.sensors.camera_model`) onto the plane and sampling
the texture (``cv2.remap``): an independent geometry from the filter's projection.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np
import skimage.data

from humimic.sensors.camera_model import Intrinsics

WALL_Z = 2.0
X_RANGE, Y_RANGE = (-3.0, 3.0), (-1.5, 1.5)
PX_PER_M = 300.0
#: The head camera: 368 x 240, 70 deg horizontal field of view, barrel distortion.
CAMERA = Intrinsics(368, 240, 262.8, 262.8, 183.5, 119.5, -0.15, 0.02)
R_CV_I = np.diag([-1.0, -1.0, 1.0])


@functools.lru_cache(maxsize=1)
def texture() -> np.ndarray:
    """The wall's texture (RGB), row 0 at the top (y = +1.5), column 0 at x = +3 (left)."""
    w = int((X_RANGE[1] - X_RANGE[0]) * PX_PER_M)
    h = int((Y_RANGE[1] - Y_RANGE[0]) * PX_PER_M)
    tex = np.full((h, w, 3), 200, np.uint8)
    tiles = [skimage.data.astronaut(), skimage.data.coffee(), skimage.data.chelsea(),
             skimage.data.rocket()]
    tw = w // 4
    for i, t in enumerate(tiles):
        tex[:, i * tw:(i + 1) * tw] = cv2.resize(t, (tw, h), interpolation=cv2.INTER_AREA)
    # the black screen, 1.22 x 0.91 m centred at the origin, inside a light frame
    c = tex_coords(np.array([[0.66, 0.505], [-0.66, -0.505]]))
    cv2.rectangle(tex, tuple(int(v) for v in c[0]), tuple(int(v) for v in c[1]),
                  (235, 235, 235), -1)
    c = tex_coords(np.array([[0.61, 0.455], [-0.61, -0.455]]))
    cv2.rectangle(tex, tuple(int(v) for v in c[0]), tuple(int(v) for v in c[1]),
                  (15, 15, 20), -1)
    return tex


def tex_coords(xy: np.ndarray) -> np.ndarray:
    """Texture pixel coordinates of wall points ``(x, y)`` (W)."""
    return np.stack([(X_RANGE[1] - xy[..., 0]) * PX_PER_M,
                     (Y_RANGE[1] - xy[..., 1]) * PX_PER_M], axis=-1)


@functools.lru_cache(maxsize=4)
def _rays(intr: Intrinsics) -> np.ndarray:
    u, v = np.meshgrid(np.arange(intr.width, dtype=float), np.arange(intr.height, dtype=float))
    xy = intr.undistort_normalized(np.stack([u, v], axis=-1), iterations=20)
    ray_cv = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
    return ray_cv @ R_CV_I  # rows: R_CV_I^T ray (the ray in I)


def render(p_W: np.ndarray, R_W_I: np.ndarray, rng: np.random.Generator | None = None,
           noise_std: float = 2.0, intr: Intrinsics = CAMERA) -> np.ndarray:
    """The RGB frame seen from ``p_W`` with orientation ``R_W_I`` (grey where no wall)."""
    ray_W = _rays(intr) @ R_W_I.T
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (WALL_Z - p_W[2]) / ray_W[..., 2]
    X = p_W + s[..., None] * ray_W
    uv = tex_coords(X[..., :2]).astype(np.float32)
    uv[~(s > 0)] = -1.0
    img = cv2.remap(texture(), uv[..., 0], uv[..., 1], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=(128, 128, 128))
    if rng is not None and noise_std > 0:
        img = np.clip(img + rng.normal(0, noise_std, img.shape), 0, 255).astype(np.uint8)
    return img
