"""The wearable interface's frames (Sugiyama & Miura), defined once for every stage.

**W** -- the paper's world frame (Fig. 5). Origin level with the screen centre (1.5 m above the
floor) and :data:`SCREEN_DISTANCE_M` in front of it; ``z`` horizontal, towards the screen;
``y`` up; ``x = y x z``, to the left of a person facing the screen. The screen's corners are
:data:`SCREEN_CORNERS_W` (the prior known features); a person at the start stands at
``(x, z) = (0, -2.5)`` (:data:`START_XZ_W`). Gravity in W is :data:`GRAVITY_W`.

Every room carries a site ``screen`` at the centre of the screen's display surface, axes as
W's (z into the wall, y up), so ``T_world_W`` follows from the room (:func:`paper_frame`)
and ground truth is available in W through ``GroundTruth.pose(name, "W")`` etc.

**I** -- the interface (head camera) frame of eqs. 8-9: origin at the optical centre, ``x``
left, ``y`` up, ``z`` along the optical axis. The head IMU is mounted at the same point with the
same axes (sites ``headcam`` and ``head_imu``). OpenCV's camera axes (x right, y down, z
forward), which :mod:`humimic.sensors.camera_model` projects with, are ``p_cv = R_CV_I p_I``.
A person standing level and facing the screen has ``R_W_I = identity``.

**A** -- the Wii remote's frame (eqs. 10-24): ``z`` towards the pointing end, ``y`` out of the
button face, ``x = y x z`` (site ``wiimote`` / ``wiimote_imu`` at the remote's centre; the
red marker sphere's centre is site ``wiimote_marker``). Held pointing forward with the
buttons up in front of a level head, ``R_I_A = identity``.

Units: m, s, rad.
"""

from __future__ import annotations

import mujoco
import numpy as np

from humimic.sensors.camera_model import make_transform

#: Name of the room site at the screen's centre (axes as W's).
SCREEN_SITE = "screen"
#: Distance from W's origin to the screen (m).
SCREEN_DISTANCE_M = 2.0
#: Width, height of the screen's display area (m).
SCREEN_SIZE_M = (1.22, 0.91)
#: Height of the screen centre (and of W's origin) above the floor (m).
SCREEN_HEIGHT_M = 1.5
#: The screen's corners in W, in the paper's order (top-left, top-right, bottom-right,
#: bottom-left as a person facing the screen sees them).
SCREEN_CORNERS_W = np.array([[0.61, 0.455, 2.0], [-0.61, 0.455, 2.0],
                             [-0.61, -0.455, 2.0], [0.61, -0.455, 2.0]])
#: Where the person starts, (x, z) in W (m).
START_XZ_W = (0.0, -2.5)
#: Gravity in W (m/s^2): an accelerometer at rest reads -GRAVITY_W rotated into its frame.
GRAVITY_W = np.array([0.0, -9.81, 0.0])
#: OpenCV camera axes <- the paper's I axes (``p_cv = R_CV_I @ p_I``); its own inverse.
R_CV_I = np.diag([-1.0, -1.0, 1.0])


def paper_frame(R_world_screen: np.ndarray, p_world_screen: np.ndarray) -> np.ndarray:
    """``T_world_W`` from the screen site's pose (axes as W's): W's origin is
    :data:`SCREEN_DISTANCE_M` in front of the screen centre, along ``-z``."""
    R = np.asarray(R_world_screen, float)
    return make_transform(R, np.asarray(p_world_screen, float) - SCREEN_DISTANCE_M * R[:, 2])


def paper_frame_of(model: mujoco.MjModel) -> np.ndarray:
    """``T_world_W`` of a compiled scene (from its ``screen`` site)."""
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    sid = model.site(SCREEN_SITE).id
    return paper_frame(d.site_xmat[sid].reshape(3, 3), d.site_xpos[sid])


def to_frame(T_world_F: np.ndarray, p_world: np.ndarray) -> np.ndarray:
    """Points ``(..., 3)`` from the world into frame F (e.g. ``to_frame(T_world_W, p)``)."""
    T = np.asarray(T_world_F, float)
    return (np.asarray(p_world, float) - T[:3, 3]) @ T[:3, :3]


def from_frame(T_world_F: np.ndarray, p_F: np.ndarray) -> np.ndarray:
    """Points ``(..., 3)`` from frame F into the world."""
    T = np.asarray(T_world_F, float)
    return np.asarray(p_F, float) @ T[:3, :3].T + T[:3, 3]


def horizontal_xz(p_W: np.ndarray) -> np.ndarray:
    """``(..., 2)`` floor-plane coordinates ``(x, z)`` of points in W (the paper's Table II)."""
    p = np.asarray(p_W, float)
    return p[..., [0, 2]]
