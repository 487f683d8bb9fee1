"""Render the scene's cameras as a sensor: images with pixel noise and radial distortion, and
the exact intrinsics/extrinsics a calibrated vision system would know.

MuJoCo renders an ideal pinhole image. Distortion is applied afterwards with a precomputed
``cv2.remap``; when the lens is barrel-distorted (k1 < 0) the ideal image is rendered larger
(same focal length) so the distorted frame has no black corners. Pixel noise is Gaussian,
drawn from a generator spawned for each frame from the run's ``numpy.random.Generator`` by
inverse-CDF table lookup (:func:`gaussian_noise`; no global random state, OpenCV's included).
The next frame's noise is generated in a worker thread while the simulation runs; generators
are spawned in frame order on the caller's thread, so the noise does not depend on thread
timing.
"""

from __future__ import annotations

import copy
import functools
import math
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import mujoco
import numpy as np
from scipy.special import ndtri

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


def hide_geoms(scene_geoms: tuple, ngeom: int, hidden: np.ndarray) -> int:
    """Make the first ``ngeom`` geoms of an updated ``MjvScene`` (``scene.geoms``) that stand for
    a model geom flagged in ``hidden (ngeom_model,)`` draw nothing (``mjGEOM_NONE``); the scene,
    not the model, is changed. Returns how many were hidden."""
    n = 0
    for g in scene_geoms[:ngeom]:
        if g.objtype == _OBJ_GEOM and hidden[g.objid]:
            g.type = _GEOM_NONE
            n += 1
    return n


def zoom_frustum(scene: mujoco.MjvScene, factor: float) -> None:
    """Widen (``factor > 1``) the updated scene's view frustum about the optical axis: the same
    as rendering with ``tan(fovy / 2)`` times ``factor``, without touching the model."""
    for cam in scene.camera:
        cam.frustum_top *= factor
        cam.frustum_bottom *= factor
        cam.frustum_center *= factor
        cam.frustum_width *= factor


_OBJ_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)
_GEOM_NONE = int(mujoco.mjtGeom.mjGEOM_NONE)
_RND_SEGMENT = int(mujoco.mjtRndFlag.mjRND_SEGMENT)
_RND_IDCOLOR = int(mujoco.mjtRndFlag.mjRND_IDCOLOR)


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
    ``mj_forward``). Renderers are created lazily, one per image size. The scene's model is
    only read: what the rig renders differently (a wider canvas for distortion, geoms outside
    the view left out, the offscreen buffer's size, which geom groups show) lives in the rig's
    own renderers, render scenes and options.
    """

    def __init__(self, scene, specs: list[CameraSpec], rng: np.random.Generator,
                 show_wiimote: bool = False):
        self.scene, self.specs, self.rng = scene, list(specs), rng
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._option = mujoco.MjvOption()
        self._option.geomgroup[3] = 1 if show_wiimote else 0
        m = scene.model
        self._geom_radius = np.where(m.geom_type == mujoco.mjtGeom.mjGEOM_PLANE, np.inf,
                                     m.geom_rbound)
        self._cam_ids = {s.name: scene.camera(s.name) for s in self.specs}
        self._mjv_cams: dict[str, mujoco.MjvCamera] = {}
        self._zoom: dict[str, float] = {}
        """tan(half the canvas' vertical field of view) over the camera's (>= 1)."""
        self._scene_geoms: dict[tuple[int, int], tuple] = {}
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
            self._zoom[s.name] = (canvas.height / 2) / canvas.fy / math.tan(fovy / 2)
            cam = mujoco.MjvCamera()
            cam.type, cam.fixedcamid = mujoco.mjtCamera.mjCAMERA_FIXED, self._cam_ids[s.name]
            self._mjv_cams[s.name] = cam
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
            # The offscreen framebuffer is sized from the model's visual/global when the
            # renderer is made: made from the rig's own copy of the model sized exactly to the
            # image (llvmpipe then renders ~10 % faster; same pixels). Scenes are updated from the
            # shared model (its materials and lights as they are now), see render_ideal.
            m = copy.copy(self.scene.model)
            m.vis.global_.offwidth, m.vis.global_.offheight = w, h
            self._renderers[key] = mujoco.Renderer(m, height=h, width=w)
            self._scene_geoms[key] = self._renderers[key].scene.geoms
        return self._renderers[key]

    def render_ideal(self, name: str, segmentation: bool = False,
                     only: np.ndarray | None = None, scale: float = 1.0) -> np.ndarray:
        """The noise-free pinhole image (or segmentation ``(H, W, 2)`` [id, type]) of a camera;
        ``only``: draw just these model geoms (ids); ``scale`` < 1: the same view at that
        fraction of the resolution (a cheaper render).

        Geoms whose bounding sphere lies outside the camera's view frustum are left out of the
        render scene (they would be clipped anyway; llvmpipe pays ~30 us per drawn geom).
        """
        r = self._updated(name, only, scale)
        if segmentation:
            r.enable_segmentation_rendering()
        try:
            return r.render()
        finally:
            if segmentation:
                r.disable_segmentation_rendering()

    def label_counts(self, name: str, geom_label: np.ndarray, n_labels: int,
                     only: np.ndarray | None = None, scale: float = 1.0) -> np.ndarray:
        """Pixels of each label ``(n_labels,)`` in the segmentation of a camera (as
        :meth:`render_ideal` with ``segmentation``, ``only`` and ``scale``); ``geom_label[g]``
        is the label of model geom ``g`` (-1: none). Counted straight from the id colours: no
        per-pixel ``(H, W, 2)`` id image is made (a third of the CPU time of a segmentation
        render at 320x240)."""
        r = self._updated(name, only, scale)
        scn = r.scene
        flags = scn.flags
        old = flags[_RND_SEGMENT], flags[_RND_IDCOLOR]
        flags[_RND_SEGMENT] = flags[_RND_IDCOLOR] = True
        try:
            rgb = r.render()
        finally:
            flags[_RND_SEGMENT], flags[_RND_IDCOLOR] = old
        segval = (rgb[..., 0].astype(np.int32) | (rgb[..., 1].astype(np.int32) << 8)
                  | (rgb[..., 2].astype(np.int32) << 16))
        counts = np.bincount(segval.ravel())
        label = np.full(len(counts), -1, np.intp)  # id colour (segid + 1, 0: none) -> label
        for g in scn.geoms[:scn.ngeom]:
            if g.objtype == _OBJ_GEOM and 0 <= g.segid < len(counts) - 1:
                label[g.segid + 1] = geom_label[g.objid]
        keep = label >= 0
        return np.bincount(label[keep], weights=counts[keep], minlength=n_labels)[
            :n_labels].astype(np.int64)

    def _updated(self, name: str, only: np.ndarray | None, scale: float) -> mujoco.Renderer:
        """The renderer of ``name``'s image at ``scale`` with its scene updated to the current
        state (the frustum-culled geoms and, with ``only``, all others drawing nothing)."""
        canvas = self._canvas[name]
        cid = self._cam_ids[name]
        d = self.scene.data
        size = (max(1, round(canvas.width * scale)), max(1, round(canvas.height * scale)))
        r = self._renderer(*size)
        hidden = ~frustum_visible(d.geom_xpos, self._geom_radius, d.cam_xpos[cid],
                                  d.cam_xmat[cid].reshape(3, 3), canvas)
        if only is not None:
            hidden[np.setdiff1d(np.arange(len(hidden)), only)] = True
        scn = r.scene
        mujoco.mjv_updateScene(self.scene.model, d, self._option, None, self._mjv_cams[name],
                               mujoco.mjtCatBit.mjCAT_ALL, scn)
        if self._zoom[name] != 1.0:  # the canvas is larger than the image: same focal length
            zoom_frustum(scn, self._zoom[name])
        hide_geoms(self._scene_geoms[size], scn.ngeom, hidden)
        return r

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


#: Uniform 16-bit draws index a table of noise values (see :func:`noise_table`).
NOISE_TABLE_SIZE = 1 << 16


@functools.cache
def noise_table(std: float) -> np.ndarray:
    """int16 pixel noise for each 16-bit uniform draw: ``std`` times the standard normal's
    inverse CDF at the centres of 65536 equal-probability bins, rounded to grey levels -- a
    Gaussian quantized as the 8-bit image quantizes it, cut off at +-4.3 sigma."""
    p = (np.arange(NOISE_TABLE_SIZE) + 0.5) / NOISE_TABLE_SIZE
    return np.rint(std * ndtri(p)).astype(np.int16)


def gaussian_noise(shape: tuple[int, ...], std: float, rng: np.random.Generator
                   ) -> np.ndarray:
    """int16 Gaussian noise (std in grey levels) drawn from ``rng`` by inverse-CDF lookup
    (:func:`noise_table`: 1.5 ms at 320x240x3 against 2.2 ms for OpenCV's ``randn``, whose
    generator is a per-thread global, and 5 ms for numpy's normal)."""
    draws = rng.integers(0, NOISE_TABLE_SIZE, shape, dtype=np.uint16)
    return np.take(noise_table(float(std)), draws)


class NoiseStream:
    """Per-frame pixel noise for one camera, the next frame's generated in the background."""

    def __init__(self, shape: tuple[int, ...], std: float, rng: np.random.Generator,
                 pool: ThreadPoolExecutor):
        self.shape, self.std, self.rng, self.pool = shape, std, rng, pool
        self._next: Future = self._submit()

    def _submit(self) -> Future:
        frame_rng = self.rng.spawn(1)[0]  # made here, in frame order
        return self.pool.submit(gaussian_noise, self.shape, self.std, frame_rng)

    def take(self) -> np.ndarray:
        noise = self._next.result()
        self._next = self._submit()
        return noise


def add_pixel_noise(image: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    """``image`` plus Gaussian noise (std in grey levels), saturated to uint8."""
    return cv2.add(image, gaussian_noise(image.shape, std, rng), dtype=cv2.CV_8U)
