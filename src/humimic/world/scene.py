"""Compose robot + avatar + room into one MuJoCo model (dm_control ``mjcf``) with named accessors.

The three MJCF files in ``models/`` are composed with :mod:`dm_control.mjcf`: the room is the
root, the robot is attached at the origin (names prefixed ``db/``) and the avatar at its
placement facing the robot (names prefixed ``human/``). Scenario parameters that change the
model (colours, eye spacing, camera aspect ratio, lighting) are applied to the MJCF tree before
compiling, so the compiled model is exactly what the scenario describes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from dm_control import mjcf

from humimic.paths import MODELS_DIR
from humimic.sensors.camera_model import fovy_from_hfov, make_transform
from humimic.world import faces
from humimic.world.frames import paper_frame_of
from humimic.world.names import (
    BASE_JOINTS,
    EYE_CAMERAS,
    EYE_HFOV_DEG,
    HUMAN_JOINTS,
    HUMAN_PREFIX,
    HUMAN_TARGETS,
    ROBOT_JOINTS,
    ROBOT_PREFIX,
)

#: Room name -> MJCF file in ``models/``.
ROOMS = {"lab": "room.xml", "sugiyama": "room_sugiyama.xml", "lab_clutter": "room_clutter.xml"}
#: Room site at which the person's (avatar) frame is placed, when the room has one.
PERSON_START_SITE = "person_start"
WIDE_HFOV_DEG = EYE_HFOV_DEG["wide"]
FOVEAL_HFOV_DEG = EYE_HFOV_DEG["foveal"]
#: MuJoCo geom group of the Wii remote (hidden unless the scenario shows it).
WIIMOTE_GROUP = 3


@dataclass(frozen=True)
class SceneOptions:
    """Everything about the scene a scenario can change. Lengths in m, colours RGB in [0, 1]."""

    distance: float = 1.2
    """Horizontal distance (m) from the robot's eye midpoint (robot in its zero pose) to the
    person's head centre (person standing in the avatar's zero pose)."""
    lateral: float = 0.0
    """Sideways offset of the person along the robot's y axis (m)."""
    skin: tuple[float, float, float] = (0.87, 0.67, 0.55)
    shirt: tuple[float, float, float] = (0.2, 0.3, 0.8)
    trousers: tuple[float, float, float] = (0.25, 0.25, 0.3)
    interocular: float = 0.07
    eye_resolution: tuple[int, int] = (320, 240)
    """Width, height of the eye cameras (sets MuJoCo's vertical fovy for the aspect ratio)."""
    wide_hfov_deg: float = WIDE_HFOV_DEG
    foveal_hfov_deg: float = FOVEAL_HFOV_DEG
    headcam_resolution: tuple[int, int] = (368, 240)
    headcam_hfov_deg: float = 70.0
    ambient: float = 0.3
    diffuse: float = 0.55
    shadows: bool = False
    msaa: bool = False
    show_wiimote: bool = False
    identity: str = faces.DEFAULT_IDENTITY
    """The person's face (one of :data:`humimic.world.faces.IDENTITY_NAMES`)."""
    show_headcam: bool = False
    """Draw the worn head camera on the forehead (only when the scenario uses it: it covers the
    brows and would hide the face from a face detector)."""
    base: str = "fixed"
    """The robot's base: ``fixed`` (welded at the pelvis, as DB) or ``planar`` (x, y, yaw
    joints with velocity actuators: a wheeled base, see :func:`add_planar_base`)."""
    room: str = "lab"
    """Room model (:data:`ROOMS`): ``lab`` (Ude & Atkeson's; the person stands ``distance``
    in front of the robot) or ``sugiyama`` (the wearable room; the person starts at its
    ``person_start`` site and ``distance``/``lateral`` do not apply)."""
    max_render_size: tuple[int, int] = field(default=(1280, 960))
    people: tuple = ()
    """Other people (:class:`humimic.world.people.Person`), attached after the tutor."""


def _robot_eye_height_and_x() -> tuple[float, float]:
    """Eye-midpoint position of the robot in its zero pose (world x, world z), from the MJCF."""
    robot = mjcf.from_path(str(MODELS_DIR / "db_humanoid.xml"))
    m = mujoco.MjModel.from_xml_string(robot.to_xml_string(), robot.get_assets())
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    p = d.site("eye_center").xpos
    return float(p[0]), float(p[2])


def compose(opts: SceneOptions) -> mjcf.RootElement:
    """The scene's MJCF tree for ``opts`` (not yet compiled)."""
    room = mjcf.from_path(str(MODELS_DIR / ROOMS[opts.room]))
    robot = mjcf.from_path(str(MODELS_DIR / "db_humanoid.xml"))
    human = mjcf.from_path(str(MODELS_DIR / "avatar.xml"))

    # Robot: eye spacing and camera fields of view for the image aspect ratio.
    robot.find("body", "L_eye").pos[1] = opts.interocular / 2.0
    robot.find("body", "R_eye").pos[1] = -opts.interocular / 2.0
    w, h = opts.eye_resolution
    for (_, kind), cam in EYE_CAMERAS.items():
        hfov = opts.wide_hfov_deg if kind == "wide" else opts.foveal_hfov_deg
        robot.find("camera", cam).fovy = math.degrees(
            fovy_from_hfov(math.radians(hfov), w, h))
    hw, hh = opts.headcam_resolution
    human.find("camera", "headcam").fovy = math.degrees(
        fovy_from_hfov(math.radians(opts.headcam_hfov_deg), hw, hh))

    if opts.base == "planar":
        add_planar_base(robot)

    # Avatar colours.
    for name, rgb in (("skin", opts.skin), ("shirt", opts.shirt), ("trousers", opts.trousers)):
        human.find("material", name).rgba = [*rgb, 1.0]

    add_face(human, opts.identity)
    if not opts.show_headcam:
        human.find("geom", "headcam").group = WIIMOTE_GROUP + 1  # a hidden group

    # Lighting and rendering quality.
    key = room.find("light", "key")
    key.ambient = [opts.ambient] * 3
    key.diffuse = [opts.diffuse] * 3
    quality = room.visual.quality
    quality.shadowsize = 4096 if opts.shadows else 0
    quality.offsamples = 4 if opts.msaa else 0
    room.visual.get_children("global").offwidth = max(opts.max_render_size[0], w, hw)
    room.visual.get_children("global").offheight = max(opts.max_render_size[1], h, hh)

    room.attach(robot)
    start = room.find("site", PERSON_START_SITE)
    if start is not None:  # the room says where the person starts (a site on the world body)
        frame = room.attach(human)  # after the robot: its keyframe's qpos stays first
        frame.pos = start.pos
        frame.quat = start.quat if start.quat is not None else [1.0, 0.0, 0.0, 0.0]
        return room
    eye_x, _ = _EYE_X_Z
    head_x_in_avatar = 0.0  # the avatar's head centre is above its origin in the zero pose
    frame = room.attach(human)
    frame.pos = [eye_x + opts.distance + head_x_in_avatar, opts.lateral, 0.0]
    frame.euler = [0.0, 0.0, math.pi]  # face the robot (avatar +x points to world -x)
    if opts.people:
        from humimic.world.people import attach_people

        attach_people(room, opts.people, eye_x, add_face)
    return room


def add_face(human: mjcf.RootElement, identity: str) -> None:
    """Texture the avatar's head with ``identity``'s face (tinted by the ``skin`` material)."""
    images = faces.cube_faces(identity)
    texture = human.asset.add(
        "texture", name="face", type="cube",
        **{f"file{k}": mjcf.Asset(faces.png_bytes(v), ".png") for k, v in images.items()})
    skin = human.find("material", "skin")
    # matte: a highlight that moves with the head over the features hides who it is
    face = human.asset.add("material", name="face", texture=texture, rgba=skin.rgba,
                           specular=0.0, shininess=0.0)
    human.find("geom", "head").material = face


_EYE_X_Z = _robot_eye_height_and_x()

#: Velocity-actuator gains of the planar base: time constants of ~0.01 s for the robot's
#: 80 kg and its ~4 kg m^2 about the vertical.
BASE_KV = {"base_x": 8000.0, "base_y": 8000.0, "base_yaw": 400.0}


def add_planar_base(robot: mjcf.RootElement) -> None:
    """Give the robot's pelvis the joints of a wheeled base (:data:`BASE_JOINTS`: slides along
    x and y, then a turn about z, in the parent's = world frame) and velocity actuators
    (``ctrl`` = joint velocity, m/s and rad/s, driven by :mod:`humimic.control.base`). The
    ``ready`` keyframe gets the base at its start pose."""
    pelvis = robot.find("body", "pelvis")
    axes = {"base_x": ("slide", [1, 0, 0]), "base_y": ("slide", [0, 1, 0]),
            "base_yaw": ("hinge", [0, 0, 1])}
    for i, name in enumerate(BASE_JOINTS):
        kind, axis = axes[name]
        pelvis.insert("joint", i, name=name, type=kind, axis=axis, damping=0.0,
                      armature=0.0, limited=False)
        robot.actuator.add("velocity", name=name, joint=name, kv=BASE_KV[name])
    for key in robot.keyframe.key:
        key.qpos = [0.0] * len(BASE_JOINTS) + list(key.qpos)
        if key.ctrl is not None:
            key.ctrl = list(key.ctrl) + [0.0] * len(BASE_JOINTS)


class Scene:
    """The compiled scene with named accessors for robot and avatar parts.

    ``model``/``data`` are plain MuJoCo objects. Robot joint ``j`` is at ``qpos[robot_qpos[j]]``;
    the avatar's configuration is the contiguous block ``qpos[human_qpos]`` (its velocities
    ``qvel[human_dof]``), in the order of :data:`humimic.world.names.HUMAN_JOINTS`.
    """

    def __init__(self, model: mujoco.MjModel, opts: SceneOptions):
        self.model = model
        self.data = mujoco.MjData(model)
        self.opts = opts
        m = model

        self.robot_joint_ids = np.array([m.joint(ROBOT_PREFIX + j).id for j in ROBOT_JOINTS])
        self.robot_qpos = m.jnt_qposadr[self.robot_joint_ids]
        self.robot_dof = m.jnt_dofadr[self.robot_joint_ids]
        self.robot_actuators = np.array([m.actuator(ROBOT_PREFIX + j).id for j in ROBOT_JOINTS])
        self.robot_range = m.jnt_range[self.robot_joint_ids].copy()
        has_base = opts.base == "planar"
        self.base_joint_ids = np.array(
            [m.joint(ROBOT_PREFIX + j).id for j in BASE_JOINTS] if has_base else [], int)
        self.base_qpos = m.jnt_qposadr[self.base_joint_ids]
        self.base_dof = m.jnt_dofadr[self.base_joint_ids]
        self.base_actuators = np.array(
            [m.actuator(ROBOT_PREFIX + j).id for j in BASE_JOINTS] if has_base else [], int)

        first = m.joint(HUMAN_PREFIX + HUMAN_JOINTS[0][0]).id
        last = m.joint(HUMAN_PREFIX + HUMAN_JOINTS[-1][0]).id
        last_is_ball = HUMAN_JOINTS[-1][1] == "ball"
        q0, q1 = m.jnt_qposadr[first], m.jnt_qposadr[last] + (4 if last_is_ball else 1)
        v0, v1 = m.jnt_dofadr[first], m.jnt_dofadr[last] + (3 if last_is_ball else 1)
        self.human_qpos = slice(int(q0), int(q1))
        self.human_dof = slice(int(v0), int(v1))
        self.human_qpos0 = m.qpos0[self.human_qpos].copy()

        self.T_world_base = self._body_pose(ROBOT_PREFIX + "pelvis", zero_pose=True)
        self.T_world_W = paper_frame_of(m)
        """Pose of the paper's frame W (Sugiyama & Miura; :mod:`humimic.world.frames`)."""
        frame_body = int(m.body(HUMAN_PREFIX + "pelvis").parentid[0])
        self.T_world_avatar = self._body_pose(frame_body, zero_pose=True)

        key = m.key(ROBOT_PREFIX + "ready").id if m.nkey else None
        if key is not None:
            mujoco.mj_resetDataKeyframe(m, self.data, key)
        else:
            mujoco.mj_resetData(m, self.data)
        mujoco.mj_forward(m, self.data)

    # ---- names -------------------------------------------------------------------------------
    def robot_site(self, name: str) -> int:
        return self.model.site(ROBOT_PREFIX + name).id

    def human_site(self, target: str) -> int:
        """Site id of a user-facing human target (``head``, ``right_hand``, ...)."""
        return self.model.site(HUMAN_PREFIX + HUMAN_TARGETS[target]).id

    def camera(self, name: str) -> int:
        """Camera id by unprefixed name: ``L_wide``, ``R_foveal``, ``headcam`` ..."""
        prefix = HUMAN_PREFIX if name == "headcam" else ROBOT_PREFIX
        return self.model.camera(prefix + name).id

    # ---- poses -------------------------------------------------------------------------------
    def _body_pose(self, body: str | int, zero_pose: bool) -> np.ndarray:
        d = mujoco.MjData(self.model) if zero_pose else self.data
        mujoco.mj_kinematics(self.model, d)
        b = self.model.body(body)
        return make_transform(d.xmat[b.id].reshape(3, 3).copy(), d.xpos[b.id].copy())

    def robot_qpos_vector(self) -> np.ndarray:
        return self.data.qpos[self.robot_qpos].copy()

    def T_world_base_now(self) -> np.ndarray:
        """The robot base's pose at the scene's current kinematics (``T_world_base`` is its pose
        at t = 0; they differ once a planar base has moved)."""
        b = self.model.body(ROBOT_PREFIX + "pelvis").id
        return make_transform(self.data.xmat[b].reshape(3, 3).copy(), self.data.xpos[b].copy())


def build_scene(opts: SceneOptions | None = None) -> Scene:
    """Compose and compile the scene for ``opts``."""
    opts = opts or SceneOptions()
    root = compose(opts)
    model = mujoco.MjModel.from_xml_string(root.to_xml_string(), root.get_assets())
    return Scene(model, opts)
