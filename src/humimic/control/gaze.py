"""Active gaze: each eye turns so a target stays at the centre of its images.

Not in the paper (its conclusion lists head-motion compensation as future work); here the eyes
move and the head does not, so the base frame stays aligned with the head and perception - which
expresses every measurement in the robot base frame with the cameras' current poses - stays
valid. Each eye's wide and foveal cameras are coaxial with the eye's +x axis, so aiming that axis
at the target centres it in both images.

The law is direct: the target's position, predicted to now, is smoothed by the same Cartesian PD
as the hands (:mod:`humimic.control.interpolation`); each eye's pan/tilt follows in closed form
(:func:`humimic.world.gaze.pan_tilt_to`, pan about the head's z then tilt about the eye's -y),
rate-limited to ``max_speed`` and kept inside the joint range.
"""

from __future__ import annotations

import mujoco
import numpy as np

from humimic.sensors.camera_model import R_MJCAM_CV
from humimic.world.gaze import pan_tilt_to
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX


def eye_angles(p_world_target: np.ndarray, p_world_eye: np.ndarray,
               R_world_parent: np.ndarray) -> tuple[float, float]:
    """Pan and tilt that aim an eye (pivot ``p_world_eye``, parent rotation ``R_world_parent``)
    at a world point."""
    return pan_tilt_to(R_world_parent.T @ (p_world_target - p_world_eye))


def rate_limit(q_prev: np.ndarray, q_des: np.ndarray, max_step: float) -> np.ndarray:
    """``q_des`` reached from ``q_prev`` by at most ``max_step`` per joint."""
    return q_prev + np.clip(q_des - q_prev, -max_step, max_step)


class Gaze:
    """Eye pan/tilt targets for both eyes from a world-frame target, once per servo tick.

    Geometry is read from the scene's current kinematics (the physical head).
    """

    def __init__(self, scene, max_speed: float, dt: float, margin: float = 0.01):
        m = scene.model
        self.data = scene.data
        self.dt = dt
        self.max_step = max_speed * dt
        self.eye_bodies = [m.body(f"{ROBOT_PREFIX}{e}_eye").id for e in ("L", "R")]
        self.parents = [int(m.body_parentid[b]) for b in self.eye_bodies]
        #: Indices into ROBOT_JOINTS of L_EP, L_ET, R_EP, R_ET.
        self.joints = np.array([ROBOT_JOINTS.index(j) for j in ("L_EP", "L_ET", "R_EP", "R_ET")])
        rng = scene.robot_range[self.joints]
        self.lo, self.hi = rng[:, 0] + margin, rng[:, 1] - margin
        self.q = np.clip(scene.data.qpos[scene.robot_qpos[self.joints]], self.lo, self.hi)
        self.qdot = np.zeros(4)
        self.saturated = 0

    def step(self, p_world_target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """New eye joint targets ``(4,)`` and their rates for a target at ``p_world_target``."""
        d = self.data
        q_des = np.empty(4)
        for i, (body, parent) in enumerate(zip(self.eye_bodies, self.parents, strict=True)):
            R = d.xmat[parent].reshape(3, 3)
            q_des[2 * i:2 * i + 2] = eye_angles(p_world_target, d.xpos[body], R)
        clipped = np.clip(q_des, self.lo, self.hi)
        if np.any(clipped != q_des):
            self.saturated += 1
        q = rate_limit(self.q, clipped, self.max_step)
        self.qdot = (q - self.q) / self.dt
        self.q = q
        return q, self.qdot


def camera_frame_point(data: mujoco.MjData, cam_id: int, p_world: np.ndarray) -> np.ndarray:
    """A world point in a MuJoCo camera's frame converted to OpenCV axes (x right, y down,
    z forward)."""
    R = data.cam_xmat[cam_id].reshape(3, 3)
    return R_MJCAM_CV @ (R.T @ (p_world - data.cam_xpos[cam_id]))
