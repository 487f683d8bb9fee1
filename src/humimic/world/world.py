"""The world at run time: the scene, the person's motion and ground truth, the robot's initial
posture, and the sensors that sample it.

Everything about the person is known before the loop starts (the avatar is kinematic): the
ground truth of every site at every physics step is evaluated on demand, a chunk of ticks at a
time (:class:`~humimic.motion.lazy_ground_truth.LazyGroundTruth`, so memory does not grow with
the run's duration), and the inertial readings likewise, a block of samples at a time
(:mod:`~humimic.sensors.inertial_stream`); the loop writes
the avatar's state into the scene each step.
"""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np

from humimic.control.base import BaseController
from humimic.motion import MotionContext, make_motion
from humimic.motion.lazy_ground_truth import LazyGroundTruth
from humimic.sensors.camera_model import CameraImage
from humimic.sensors.cameras import CameraRig, CameraSpec
from humimic.sensors.clock import Clock, Schedule
from humimic.sensors.faults import SensorFaults
from humimic.sensors.inertial_stream import stream_inertial
from humimic.sensors.visibility import Visibility
from humimic.world.gaze import pan_tilt_to
from humimic.world.names import EYE_CAMERAS, ROBOT_JOINTS, ROBOT_PREFIX
from humimic.world.people import PeopleMotion
from humimic.world.person_view import person_view
from humimic.world.scene import SceneOptions, build_scene


def scene_options(scenario) -> SceneOptions:
    """The :class:`SceneOptions` a scenario asks for."""
    h, c, light = scenario.human, scenario.cameras, scenario.lighting
    return SceneOptions(
        distance=h.distance, lateral=h.lateral, skin=h.skin, shirt=h.shirt,
        trousers=h.trousers, interocular=scenario.robot.interocular,
        eye_resolution=c.resolution,
        headcam_resolution=scenario.sensors.head_camera.resolution,
        headcam_hfov_deg=scenario.sensors.head_camera.hfov_deg,
        ambient=light.ambient, diffuse=light.diffuse, shadows=light.shadows, msaa=light.msaa,
        show_wiimote=h.wiimote, room=scenario.room, base=scenario.robot.base,
        identity=h.identity, show_headcam=scenario.sensors.head_camera.enabled,
        people=tuple(h.people),
    )


def eye_camera_names(cameras) -> list[str]:
    """Scene camera names for the scenario's ``cameras`` section (left first)."""
    eyes = {"stereo": ("left", "right"), "left": ("left",), "right": ("right",)}[cameras.eyes]
    kinds = ("wide", "foveal") if cameras.which == "both" else (cameras.which,)
    return [EYE_CAMERAS[(eye, kind)] for kind in kinds for eye in eyes]


class World:
    """Scene + clock + ground truth + sensors for one scenario and seed."""

    def __init__(self, scenario, rngs: dict[str, np.random.Generator]):
        self.scenario = scenario
        self.scene = build_scene(scene_options(scenario))
        m = self.scene.model
        m.opt.timestep = 1.0 / scenario.timing.physics_rate
        self.clock = Clock(scenario.timing.physics_rate)
        self.n_ticks = self.clock.ticks_for(scenario.duration)

        ctx = MotionContext.from_scene(self.scene, scenario.duration, rngs["motion"])
        self.motion = make_motion(scenario.human.motion, ctx)
        self.gt = LazyGroundTruth.for_run(self.scene, self.motion, self.n_ticks,
                                          self.clock.physics_rate)
        """Ground truth at every physics tick, evaluated on demand (flat memory in duration)."""
        self.times = self.gt.t
        self.people = (PeopleMotion(m, scenario.human.people) if scenario.human.people
                       else None)
        """The other people's walks and head truth (``human.people``), or None."""
        self.set_robot_pose()
        self.base = BaseController(self.scene) if scenario.robot.base == "planar" else None
        """The planar base's controller (``robot.base: planar``), stepped by the simulation
        at the servo rate; it holds the start pose until a stage calls ``set_target``."""

        c = scenario.cameras
        self.eye_cameras = eye_camera_names(c) if c.enabled else []
        self.eye_rig = CameraRig(
            self.scene,
            [CameraSpec(n, *c.resolution, c.noise_std, *c.distortion) for n in self.eye_cameras],
            rngs["cameras"], show_wiimote=scenario.human.wiimote) if c.enabled else None
        hc = scenario.sensors.head_camera
        self.head_rig = (CameraRig(self.scene, [CameraSpec("headcam", *hc.resolution,
                                                           hc.noise_std, *hc.distortion)],
                                   rngs["headcam"], show_wiimote=scenario.human.wiimote)
                         if hc.enabled else None)
        self.imu = self._inertial("head_imu", scenario.sensors.imu, rngs["imu"])
        self.wiimote = self._inertial("wiimote", scenario.sensors.wiimote, rngs["wiimote"])
        self.faults = SensorFaults(scenario, self.eye_cameras, rngs)
        """Lost, frozen and covered frames, lost inertial samples (applied when published)."""
        self.visibility: Visibility | None = None
        """Visibility ground truth of the eye cameras, once a stage asked for it
        (:meth:`track_visibility`); sampled by the simulation at camera frames."""
        self.person_view = person_view(self)
        """Whether the scripted person stays in the eyes' start view and in front of the robot
        (:mod:`~humimic.world.person_view`; warns once here); None without eye cameras."""

    def track_visibility(self) -> Visibility | None:
        """Start (or return) the eye cameras' visibility ground truth; None without cameras
        or with ``cameras.visibility_rate: 0``."""
        if (self.visibility is None and self.eye_rig is not None
                and self.scenario.cameras.visibility_rate > 0.0):
            self.visibility = Visibility(self.eye_rig, list(self.eye_cameras),
                                         self.scenario.cameras.visibility_rate)
        return self.visibility

    @property
    def T_world_W(self) -> np.ndarray:
        """Pose of the paper's frame W in the world (:mod:`humimic.world.frames`)."""
        return self.scene.T_world_W

    def capture_headcam(self, t: float) -> CameraImage:
        """The head camera's frame at ``t``: the image and its intrinsics (with distortion);
        its pose is withheld (NaN) -- a wearable system estimates it. The true pose is
        ``gt.pose("headcam", frame)`` (frame I; OpenCV axes are ``R_CV_I`` away)."""
        image = self.head_rig.capture_one("headcam", t)
        nan = np.full((4, 4), np.nan)
        return replace(image, camera=replace(image.camera, T_base_cam=nan, T_world_cam=nan))

    # ---- the person ------------------------------------------------------------------------
    def apply_human(self, tick: int) -> None:
        """Write the avatar's configuration and velocity at ``tick`` into the scene."""
        d, s = self.scene.data, self.scene
        d.qpos[s.human_qpos] = self.gt.qpos[tick]
        d.qvel[s.human_dof] = self.gt.qvel[tick]
        if self.people is not None:
            self.people.apply(d.qpos, self.times[tick])

    def _inertial(self, which: str, cfg, rng):
        if not cfg.enabled:
            return None
        ticks = np.array(Schedule(cfg.rate, self.clock.physics_rate).ticks(self.n_ticks))
        acc, gyro = self.gt.inertial(which)
        R_W_sensor = (self.gt.rotation(which, "W") if getattr(cfg, "orientation", False)
                      else None)

        def truth(idx: np.ndarray):  # the ground truth at samples idx, evaluated on demand
            k = ticks[idx]
            return acc[k], gyro[k], R_W_sensor[k] if R_W_sensor is not None else None

        return stream_inertial(self.times[ticks], truth, cfg, rng, R_W_sensor is not None), ticks

    # ---- the robot -------------------------------------------------------------------------
    def set_robot_pose(self) -> None:
        """Initial posture from the scenario: named pose, joint overrides, eyes on a target."""
        s, m, d = self.scene, self.scene.model, self.scene.data
        cfg = self.scenario.robot
        if cfg.pose == "zero" or not m.nkey:
            q = np.zeros(len(ROBOT_JOINTS))
        else:
            q = m.key(ROBOT_PREFIX + "ready").qpos[s.robot_qpos].copy()
        if isinstance(cfg.pose, dict):
            for name, angle in cfg.pose.items():
                q[ROBOT_JOINTS.index(name)] = angle
        q = np.clip(q, s.robot_range[:, 0], s.robot_range[:, 1])
        d.qpos[s.robot_qpos] = q
        d.qvel[:] = 0.0
        self.apply_human(0)
        mujoco.mj_forward(m, d)
        if cfg.look_at is not None:
            self._look_at(cfg.look_at)
        d.ctrl[s.robot_actuators] = d.qpos[s.robot_qpos]
        mujoco.mj_forward(m, d)

    def _look_at(self, target) -> None:
        if isinstance(target, str):
            self.look_at_point(self.gt.p_world(target)[0])
        else:
            self.look_at_point(np.asarray(target, dtype=float))

    def look_at_point(self, p_world: np.ndarray) -> None:
        """Set both eyes' pan and tilt (and their servo targets) to aim at a world point, at
        rest (joint range permitting)."""
        s, m, d = self.scene, self.scene.model, self.scene.data
        for eye in ("L", "R"):
            body = m.body(f"{ROBOT_PREFIX}{eye}_eye")
            parent = body.parentid[0]
            R_world_parent = d.xmat[parent].reshape(3, 3)
            p_parent = R_world_parent.T @ (p_world - d.xpos[body.id])
            pan, tilt = pan_tilt_to(p_parent)
            for joint, angle in ((f"{eye}_EP", pan), (f"{eye}_ET", tilt)):
                j = ROBOT_JOINTS.index(joint)
                lo, hi = s.robot_range[j]
                d.qpos[s.robot_qpos[j]] = np.clip(angle, lo, hi)
                d.qvel[s.robot_dof[j]] = 0.0
                d.ctrl[s.robot_actuators[j]] = d.qpos[s.robot_qpos[j]]
        mujoco.mj_forward(m, d)

    def close(self) -> None:
        if self.eye_rig is not None:
            self.eye_rig.close()
        if self.head_rig is not None:
            self.head_rig.close()
