"""Names of the robot's and the avatar's joints, sites and cameras (without scene prefixes)."""

from __future__ import annotations

ROBOT_PREFIX = "db/"
HUMAN_PREFIX = "human/"

#: The robot's 30 joints, in qpos / actuator order.
ROBOT_JOINTS: tuple[str, ...] = (
    "B_TR", "B_TAA", "B_TFE",
    "B_HR", "B_HN", "B_HT",
    "L_EP", "L_ET", "R_EP", "R_ET",
    "R_SFE", "R_SAA", "R_HR", "R_EB", "R_WR", "R_WFE", "R_WAA",
    "L_SFE", "L_SAA", "L_HR", "L_EB", "L_WR", "L_WFE", "L_WAA",
    "R_HFE", "R_HAA", "R_KFE",
    "L_HFE", "L_HAA", "L_KFE",
)
#: The mobile base's joints (``robot.base: planar``), in qpos / actuator order: slides along
#: the world's x and y, then a turn about the vertical; all 0 at the start pose, so their
#: values are the base's pose in the robot's start frame (Sugiyama & Miura's R, Fig. 6).
BASE_JOINTS = ("base_x", "base_y", "base_yaw")
EYE_JOINTS = ("L_EP", "L_ET", "R_EP", "R_ET")
HEAD_JOINTS = ("B_HR", "B_HN", "B_HT")
TORSO_JOINTS = ("B_TR", "B_TAA", "B_TFE")
ROBOT_SITES = ("base", "head", "eye_center", "L_eye", "R_eye", "R_palm", "L_palm",
               "R_elbow", "L_elbow")
#: Eye cameras: (eye, kind) -> camera name.
EYE_CAMERAS = {
    ("left", "wide"): "L_wide",
    ("right", "wide"): "R_wide",
    ("left", "foveal"): "L_foveal",
    ("right", "foveal"): "R_foveal",
}

#: Horizontal field of view (deg) of each kind of eye camera.
EYE_HFOV_DEG = {"wide": 100.0, "foveal": 24.0}

#: The avatar's joints in qpos order and their types.
HUMAN_JOINTS: tuple[tuple[str, str], ...] = (
    ("root_x", "slide"), ("root_y", "slide"), ("root_z", "slide"), ("root_rot", "ball"),
    ("spine", "ball"), ("neck", "ball"),
    ("r_shoulder", "ball"), ("r_elbow", "hinge"), ("r_wrist", "ball"),
    ("l_shoulder", "ball"), ("l_elbow", "hinge"), ("l_wrist", "ball"),
    ("r_hip", "ball"), ("r_knee", "hinge"), ("r_ankle", "ball"),
    ("l_hip", "ball"), ("l_knee", "hinge"), ("l_ankle", "ball"),
)
#: Ground-truth sites on the avatar: user-facing target name -> site name.
HUMAN_TARGETS = {
    "head": "head",
    "right_hand": "r_hand",
    "left_hand": "l_hand",
    "right_wrist": "r_wrist",
    "left_wrist": "l_wrist",
    "right_elbow": "r_elbow",
    "left_elbow": "l_elbow",
    "right_shoulder": "r_shoulder",
    "left_shoulder": "l_shoulder",
    "pelvis": "pelvis",
    "head_imu": "head_imu",
    "wiimote": "wiimote_imu",
    "wiimote_marker": "wiimote_marker",
    "headcam": "headcam",
}
#: Colour classes of the avatar: class -> its materials (without prefix). The head wears the
#: ``face`` material (the skin colour times a shading texture, :mod:`humimic.world.faces`), so
#: a skin model must be learned from both, or the head is missed.
COLOR_CLASSES: dict[str, tuple[str, ...]] = {
    "skin": ("skin", "face"),
    "shirt": ("shirt",),
    "trousers": ("trousers",),
    "marker": ("marker",),
}
#: The avatar's geoms that make up each visible target (visibility ground truth).
TARGET_GEOMS: dict[str, tuple[str, ...]] = {
    "head": ("head",),
    "right_hand": ("r_hand",),
    "left_hand": ("l_hand",),
}
