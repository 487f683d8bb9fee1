"""Render the avatar's face through a robot eye camera under chosen views (no simulation loop).

Used to train the eigenface recogniser on rendered crops, to measure the face detector on
rendered faces, and by tests. One scene is compiled per identity (~0.25 s); distance, lateral
offset, head orientation and lighting change between renders without recompiling: the avatar's
root slides move the person, its neck ball turns the head, the eyes are aimed at the head
centre, and the key light's ambient/diffuse levels are set in the compiled model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.world.gaze import pan_tilt_to
from humimic.world.names import HUMAN_PREFIX, ROBOT_JOINTS, ROBOT_PREFIX
from humimic.world.scene import SceneOptions, build_scene

FACE_WIDTH_M = 0.156
"""Width of the head (twice the head ellipsoid's lateral semi-axis): a face's size in pixels
is this width projected at the head centre's depth (``f * 0.156 / z``)."""


@dataclass(frozen=True)
class FaceView:
    """Where the person stands and how the head is turned and lit for one render."""

    distance: float
    """Eye-midpoint to head-centre distance along the robot's x (m)."""
    lateral: float = 0.0
    """Sideways offset of the person along the robot's y (m)."""
    yaw_deg: float = 0.0
    """Head turn about the vertical (+ = to the person's left)."""
    pitch_deg: float = 0.0
    """Head nod (+ = chin down)."""
    roll_deg: float = 0.0
    """Head tilt towards a shoulder."""
    ambient: float = 0.3
    diffuse: float = 0.55
    aim_offset: tuple[float, float] = (0.0, 0.0)
    """Where the eyes look relative to the head centre (m, along the robot's y and z): moves the
    face away from the image centre."""
    skin: tuple[float, float, float] | None = None
    """Skin colour (RGB in [0, 1]) of the face and hands; None: the studio's."""


@dataclass(frozen=True)
class FaceShot:
    """A rendered frame and where the face truly is in it."""

    image: np.ndarray
    """RGB uint8 ``(H, W, 3)``."""
    center_px: np.ndarray
    """Head centre projected into the image ``(u, v)``."""
    size_px: float
    """The face's width in pixels (:data:`FACE_WIDTH_M` at the head centre's depth)."""
    view: FaceView


class FaceStudio:
    """One identity's avatar in the scene, rendered by the robot's eye cameras.

    ``cameras`` are eye camera names (``L_foveal``, ``L_wide`` ...); the first is the default
    of :meth:`render`. Pixel noise (grey levels) is drawn from ``rng``.
    """

    def __init__(self, identity: str, cameras: str | tuple[str, ...] = ("L_foveal", "L_wide"),
                 resolution: tuple[int, int] = (320, 240), noise_std: float = 2.0,
                 skin: tuple[float, float, float] = (0.87, 0.67, 0.55),
                 rng: np.random.Generator | None = None):
        cameras = (cameras,) if isinstance(cameras, str) else tuple(cameras)
        self.identity, self.cameras = identity, cameras
        self.opts = SceneOptions(identity=identity, skin=skin, eye_resolution=resolution,
                                 distance=1.5)
        self.scene = build_scene(self.opts)
        m, s = self.scene.model, self.scene
        self.rig = CameraRig(s, [CameraSpec(c, *resolution, noise_std) for c in cameras],
                             rng if rng is not None else np.random.default_rng(0))
        self._key_light = m.light("key").id
        self._skin_materials = [m.material(HUMAN_PREFIX + n).id for n in ("skin", "face")]
        self._q_root = {j: m.jnt_qposadr[m.joint(HUMAN_PREFIX + j).id] for j in (
            "root_x", "root_y")}
        self._q_neck = m.jnt_qposadr[m.joint(HUMAN_PREFIX + "neck").id]
        self._head_site = s.human_site("head")
        self._ready = m.key(ROBOT_PREFIX + "ready").qpos.copy() if m.nkey else m.qpos0.copy()

    def render(self, view: FaceView, camera: str | None = None) -> FaceShot:
        """Render ``view`` through ``camera`` (default: the first of the studio's)."""
        camera = camera or self.cameras[0]
        m, d, s = self.scene.model, self.scene.data, self.scene
        d.qpos[:] = self._ready
        d.qpos[s.human_qpos] = s.human_qpos0
        # the avatar faces the robot (avatar x = world -x, avatar y = world -y)
        d.qpos[self._q_root["root_x"]] = self.opts.distance - view.distance
        d.qpos[self._q_root["root_y"]] = -(view.lateral - self.opts.lateral)
        R = Rotation.from_euler("ZYX", np.radians([view.yaw_deg, view.pitch_deg,
                                                   view.roll_deg]))
        x, y, z, w = R.as_quat()
        d.qpos[self._q_neck:self._q_neck + 4] = (w, x, y, z)
        skin = view.skin if view.skin is not None else self.opts.skin
        m.mat_rgba[self._skin_materials, :3] = skin
        m.light_ambient[self._key_light] = view.ambient
        m.light_diffuse[self._key_light] = view.diffuse
        mujoco.mj_kinematics(m, d)
        self._aim_eyes(d.site_xpos[self._head_site] + np.array([0.0, *view.aim_offset]))
        mujoco.mj_kinematics(m, d)
        mujoco.mj_camlight(m, d)
        shot = self.rig.capture_one(camera, 0.0)
        p_cam = shot.camera.T_world_cam[:3, :3].T @ (
            d.site_xpos[self._head_site] - shot.camera.T_world_cam[:3, 3])
        intr = shot.camera.intrinsics
        uv = intr.project(p_cam[None])[0]
        return FaceShot(shot.image, uv, float(intr.fx * FACE_WIDTH_M / p_cam[2]), view)

    def _aim_eyes(self, p_world: np.ndarray) -> None:
        m, d, s = self.scene.model, self.scene.data, self.scene
        for eye in ("L", "R"):
            body = m.body(f"{ROBOT_PREFIX}{eye}_eye")
            R_world_parent = d.xmat[body.parentid[0]].reshape(3, 3)
            pan, tilt = pan_tilt_to(R_world_parent.T @ (p_world - d.xpos[body.id]))
            for joint, angle in ((f"{eye}_EP", pan), (f"{eye}_ET", tilt)):
                j = ROBOT_JOINTS.index(joint)
                lo, hi = s.robot_range[j]
                d.qpos[s.robot_qpos[j]] = float(np.clip(angle, lo, hi))

    def close(self) -> None:
        self.rig.close()

    def __enter__(self) -> FaceStudio:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def size_to_distance(size_px: float, hfov_deg: float, width: int = 320) -> float:
    """The distance (m) at which a face spans ``size_px`` in a camera of ``hfov_deg``."""
    fx = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
    return fx * FACE_WIDTH_M / size_px
