"""Render the scene's cameras as a sensor: images with pixel noise and radial distortion, and
the exact intrinsics/extrinsics a calibrated vision system would know.

MuJoCo renders an ideal pinhole image. Distortion is applied afterwards with a precomputed
``cv2.remap``; when the lens is barrel-distorted (k1 < 0) the ideal image is rendered larger
(same focal length) so the distorted frame has no black corners. Pixel noise is Gaussian,
drawn by OpenCV's generator seeded from the run's ``numpy.random.Generator`` for each frame
(4x faster than numpy's normal at 320x240 and still reproducible). The next frame's noise is
generated in a worker thread while the simulation runs (OpenCV releases the GIL); seeds are
drawn in frame order on the caller's thread, so the noise does not depend on thread timing.
"""

from __future__ import annotations

import math
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import mujoco
import numpy as np

from humimic.sensors.camera_model import (
    R_MJCAM_CV,
    CameraImage,
    CameraModel,
    Intrinsics,
    invert_transform,
    make_transform,
)


@dataclass(frozen=True)
class CameraSpec:
    """One camera as a sensor. ``name`` is the scene camera without prefix (``L_wide``)."""

    name: str
    width: int
    height: int
    noise_std: float = 0.0
    k1: float = 0.0
    k2: float = 0.0


#: MuJoCo geom group used, during one render call, for geoms outside the camera's frustum.
CULLED_GROUP = 5


def frustum_visible(p_world: np.ndarray, radius: np.ndarray, p_world_cam: np.ndarray,
                    R_world_mjcam: np.ndarray, intr: Intrinsics) -> np.ndarray:
    """Which spheres (centres ``(N, 3)``, radii ``(N,)``) may intersect a pinhole camera's view
    frustum (conservative: a sphere is kept unless it is wholly outside one side plane)."""
    p = (p_world - p_world_cam) @ (R_world_mjcam @ R_MJCAM_CV)  # camera frame, z forward
    tx = (intr.width / 2.0) / intr.fx
    ty = (intr.height / 2.0) / intr.fy
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    with np.errstate(invalid="ignore"):  # inf radius (planes) compare as visible
        inside_x = np.abs(x) - tx * z <= radius * math.hypot(1.0, tx)
        inside_y = np.abs(y) - ty * z <= radius * math.hypot(1.0, ty)
        return (z >= -radius) & inside_x & inside_y


def distortion_maps(intr: Intrinsics, src: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """For each pixel of the distorted image ``intr``, where to sample the ideal image ``src``."""
    u, v = np.meshgrid(np.arange(intr.width, dtype=np.float64),
                       np.arange(intr.height, dtype=np.float64))
    xy = intr.undistort_normalized(np.stack([u, v], axis=-1))
    map_x = (src.fx * xy[..., 0] + src.cx).astype(np.float32)
    map_y = (src.fy * xy[..., 1] + src.cy).astype(np.float32)
    return map_x, map_y


def ideal_canvas(intr: Intrinsics) -> Intrinsics:
    """Pinhole intrinsics (same focal length) large enough to cover a distorted image."""
    if intr.k1 == 0.0 and intr.k2 == 0.0:
        return Intrinsics(intr.width, intr.height, intr.fx, intr.fy, intr.cx, intr.cy)
    corners = np.array([[0, 0], [intr.width - 1, 0], [0, intr.height - 1],
                        [intr.width - 1, intr.height - 1], [0, intr.cy], [intr.cx, 0]])
    xy = np.abs(intr.undistort_normalized(corners))
    half_w = max(intr.cx, float(xy[:, 0].max()) * intr.fx) + 2
    half_h = max(intr.cy, float(xy[:, 1].max()) * intr.fy) + 2
    w, h = 2 * math.ceil(half_w) + 1, 2 * math.ceil(half_h) + 1
    return Intrinsics(w, h, intr.fx, intr.fy, (w - 1) / 2.0, (h - 1) / 2.0)


class CameraRig:
    """Renders a set of cameras of a :class:`humimic.world.Scene` at the current state.

    Call :meth:`capture` after the scene's kinematics are up to date (``mj_step1`` or
    ``mj_forward``). Renderers are created lazily, one per image size.
    """

    def __init__(self, scene, specs: list[CameraSpec], rng: np.random.Generator,
                 show_wiimote: bool = False):
        self.scene, self.specs, self.rng = scene, list(specs), rng
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._option = mujoco.MjvOption()
        self._option.geomgroup[3] = 1 if show_wiimote else 0
        self._option.geomgroup[CULLED_GROUP] = 0
        m = scene.model
        self._geom_radius = np.where(m.geom_type == mujoco.mjtGeom.mjGEOM_PLANE, np.inf,
                                     m.geom_rbound)
        self._cam_ids = {s.name: scene.camera(s.name) for s in self.specs}
        self._intrinsics: dict[str, Intrinsics] = {}
        self._canvas: dict[str, Intrinsics] = {}
        self._maps: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._noise: dict[str, NoiseStream] = {}
        self._pool: ThreadPoolExecutor | None = None
        self._T_base_world = invert_transform(scene.T_world_base)
        for s in self.specs:
            fovy = math.radians(m.cam_fovy[self._cam_ids[s.name]])
            intr = Intrinsics.from_fovy(fovy, s.width, s.height, s.k1, s.k2)
            self._intrinsics[s.name] = intr
            canvas = ideal_canvas(intr)
            self._canvas[s.name] = canvas
            if (s.k1, s.k2) != (0.0, 0.0):
                self._maps[s.name] = distortion_maps(intr, canvas)
            if s.noise_std > 0.0:
                if self._pool is None:
                    self._pool = ThreadPoolExecutor(1, thread_name_prefix="pixel-noise")
                self._noise[s.name] = NoiseStream((s.height, s.width, 3), s.noise_std, rng,
                                                  self._pool)

    def prepare(self) -> None:
        """Create the renderers now (a GL context and MuJoCo's render context: ~0.05 s each,
        otherwise paid by the first frame)."""
        for name in self._cam_ids:
            canvas = self._canvas[name]
            self._renderer(canvas.width, canvas.height)

    def intrinsics(self, name: str) -> Intrinsics:
        return self._intrinsics[name]

    def camera_model(self, name: str) -> CameraModel:
        """The camera's intrinsics and current pose (OpenCV axes) in world and base frames."""
        d, cid = self.scene.data, self._cam_ids[name]
        R_world_cam = d.cam_xmat[cid].reshape(3, 3) @ R_MJCAM_CV
        T_world_cam = make_transform(R_world_cam, d.cam_xpos[cid].copy())
        T_base_cam = self._T_base_world @ T_world_cam
        return CameraModel(name, self._intrinsics[name], T_base_cam, T_world_cam)

    def _renderer(self, w: int, h: int) -> mujoco.Renderer:
        key = (w, h)
        if key not in self._renderers:
            # The offscreen framebuffer is sized from the model's visual/global at creation:
            # make it exactly the image (llvmpipe then renders ~10 % faster; same pixels).
            g = self.scene.model.vis.global_
            size = g.offwidth, g.offheight
            g.offwidth, g.offheight = w, h
            try:
                self._renderers[key] = mujoco.Renderer(self.scene.model, height=h, width=w)
            finally:
                g.offwidth, g.offheight = size
        return self._renderers[key]

    def render_ideal(self, name: str, segmentation: bool = False,
                     only: np.ndarray | None = None, scale: float = 1.0) -> np.ndarray:
        """The noise-free pinhole image (or segmentation ``(H, W, 2)`` [id, type]) of a camera.

        Geoms whose bounding sphere lies outside the camera's view frustum are left out of the
        scene (they would be clipped anyway; llvmpipe pays ~30 us per drawn geom). ``only``:
        draw just these geom ids (e.g. a part of the person without what hides it). ``scale``
        < 1: the same view at that fraction of the resolution (a cheaper render).
        """
        canvas = self._canvas[name]
        cid = self._cam_ids[name]
        m, d = self.scene.model, self.scene.data
        fovy0 = m.cam_fovy[cid]
        if canvas.height != self._intrinsics[name].height:
            m.cam_fovy[cid] = math.degrees(2 * math.atan((canvas.height / 2) / canvas.fy))
        r = self._renderer(max(1, round(canvas.width * scale)),
                           max(1, round(canvas.height * scale)))
        hidden = ~frustum_visible(d.geom_xpos, self._geom_radius, d.cam_xpos[cid],
                                  d.cam_xmat[cid].reshape(3, 3), canvas)
        if only is not None:
            hidden |= ~np.isin(np.arange(m.ngeom), only)
        groups = m.geom_group[hidden].copy()
        m.geom_group[hidden] = CULLED_GROUP
        try:
            if segmentation:
                r.enable_segmentation_rendering()
            r.update_scene(d, cid, self._option)
            return r.render()
        finally:
            if segmentation:
                r.disable_segmentation_rendering()
            m.cam_fovy[cid] = fovy0
            m.geom_group[hidden] = groups

    def capture_one(self, name: str, t: float) -> CameraImage:
        image = self.render_ideal(name)
        if name in self._maps:
            map_x, map_y = self._maps[name]
            image = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_REPLICATE)
        if name in self._noise:
            image = cv2.add(image, self._noise[name].take(), dtype=cv2.CV_8U)
        return CameraImage(t, self.camera_model(name), image)

    def capture(self, t: float, names: list[str] | None = None) -> dict[str, CameraImage]:
        """Render ``names`` (default: every camera of the rig) at simulated time ``t``."""
        return {n: self.capture_one(n, t) for n in (names or [s.name for s in self.specs])}

    def close(self) -> None:
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def gaussian_noise(shape: tuple[int, ...], std: float, seed: int) -> np.ndarray:
    """int16 Gaussian noise (std in grey levels) from OpenCV's generator seeded with ``seed``
    (OpenCV's generator is per thread: seeding and drawing happen in the calling thread)."""
    cv2.setRNGSeed(seed)
    noise = np.empty(shape, np.int16)
    # a single-channel view: with a 3-channel array OpenCV would use std only for channel 0
    cv2.randn(noise.reshape(shape[0], -1), 0.0, float(std))
    return noise


class NoiseStream:
    """Per-frame pixel noise for one camera, the next frame's generated in the background."""

    def __init__(self, shape: tuple[int, ...], std: float, rng: np.random.Generator,
                 pool: ThreadPoolExecutor):
        self.shape, self.std, self.rng, self.pool = shape, std, rng, pool
        self._next: Future = self._submit()

    def _submit(self) -> Future:
        seed = int(self.rng.integers(0, 2**31 - 1))  # drawn here, in frame order
        return self.pool.submit(gaussian_noise, self.shape, self.std, seed)

    def take(self) -> np.ndarray:
        noise = self._next.result()
        self._next = self._submit()
        return noise


def add_pixel_noise(image: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    """``image`` plus Gaussian noise (std in grey levels), saturated to uint8."""
    noise = gaussian_noise(image.shape, std, int(rng.integers(0, 2**31 - 1)))
    return cv2.add(image, noise, dtype=cv2.CV_8U)
