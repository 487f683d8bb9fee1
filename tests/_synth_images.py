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
    xy = intr.undistort_normalized(np.stack([u, v], axis=-1))
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


# ---- a walk in front of the wall, and the estimator run over it ----------------------------
def _rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def walk(t: float, amp: float = 0.6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pose ``(p_W, R_W_I)`` and acceleration ``a_W`` of a head swaying sideways while walking
    slowly towards the wall, with a small head bob, yaw and pitch."""
    w1, w2 = 0.8, 2 * np.pi * 1.8
    p = np.array([amp * np.sin(w1 * t), 0.02 * np.sin(w2 * t), -2.5 + 0.25 * t])
    a = np.array([-amp * w1**2 * np.sin(w1 * t), -0.02 * w2**2 * np.sin(w2 * t), 0.0])
    R = _rot_y(0.12 * np.sin(0.6 * t)) @ _rot_x(0.04 * np.sin(1.1 * t))
    return p, R, a


def run_wall(duration: float = 2.0, seed: int = 0, imu_rate: float = 180.0,
             cam_rate: float = 30.0, settings=None, mask_fn=None, cover=None):
    """Run :class:`WearableSlam` over :func:`walk` rendered on the wall. Returns the estimator,
    the frame reports and ``(t, p_true, p_est)`` at the frames. ``cover``: (t0, t1) during
    which the lens is covered (a black frame)."""
    from humimic.estimation.ekf.estimator import EstimatorSettings, WearableSlam
    from humimic.estimation.ekf.motion_model import initial_state
    from humimic.motion import quat

    rng = np.random.default_rng(seed)
    g_W = np.array([0.0, -9.81, 0.0])
    p0, R0, _ = walk(0.0)
    x0 = initial_state(p=p0, q=quat.from_matrix(R0))
    P0 = np.diag(np.r_[np.full(3, 1e-6), np.full(4, 1e-8), np.full(3, 0.1**2),
                       np.full(3, 0.1**2), np.full(3, 1.0), np.full(3, 1e-4)])
    from _synth_slam import SCREEN
    est = WearableSlam(0.0, x0, P0, CAMERA, R_CV_I, g_W, SCREEN,
                       settings or EstimatorSettings())
    n_imu = int(duration * imu_rate)
    t_imu = np.arange(1, n_imu + 1) / imu_rate
    t_cam = np.arange(0, int(duration * cam_rate) + 1) / cam_rate
    events = sorted([(t, 0) for t in t_imu] + [(t, 1) for t in t_cam])
    reports, truth, estimate = [], [], []
    for t, kind in events:
        p, R, a = walk(t)
        if kind == 0:
            f_I = R.T @ (a - g_W) + 0.05 * rng.standard_normal(3)
            dR = _rot_y(np.radians(0.25) * rng.standard_normal()) @ _rot_x(
                np.radians(0.25) * rng.standard_normal())
            est.on_imu(t, f_I, R @ dR)
        else:
            img = render(p, R, rng)
            if cover is not None and cover[0] <= t < cover[1]:
                img = np.zeros_like(img)
            mask = mask_fn(t, img) if mask_fn is not None else None
            reports.append(est.on_frame(t, img, mask))
            truth.append(p)
            estimate.append(est.x[0:3].copy())
    return est, reports, (t_cam, np.array(truth), np.array(estimate))
