"""Imitation from tracked joint angles (Menezes et al. sec. 7.2, ``mimic.mode: joints``).

The paper animated HRP2 from its two-arm tracker's angles. Here the angles of a tracker on
the ``poses`` topic (``mimic.tracker``; TBP and the kernel particle filter estimate DB's own
``SFE SAA HR EB`` per arm, :mod:`humimic.bodymodel.kinematics`) are clamped into DB's joint
ranges (minus ``ik.limit_margin``), low-pass filtered (first order, ``interpolation.omega``)
and sent to the position servos; the person's right arm drives the robot's right arm. Every
other joint holds its start value.

Scores (``mimicry.joints.*``): per-DOF and overall RMS error (deg) of the robot's measured
joint angles against the person's true angles, and the RMS distance (mm) between the robot's
elbow and wrist and where DB's elbow and wrist would be with the person's true angles (the
person's arm scaled to DB's), both in DB's torso frame -- over the ticks after the first
pose arrived.
"""

from __future__ import annotations

import numpy as np

from humimic.bodymodel.avatar import truth_angles
from humimic.bodymodel.dimensions import db_skeleton
from humimic.bodymodel.forward_kernel import segment_frames
from humimic.bodymodel.kinematics import ARM_DOFS, DOF_NAMES
from humimic.control.decimate import Decimator
from humimic.control.servo import Servo
from humimic.maths.stats import rmse
from humimic.pipeline.stage import Stage
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX

ARM_NAMES = ARM_DOFS["R"] + ARM_DOFS["L"]
JOINT_IDX = np.array([ROBOT_JOINTS.index(n) for n in ARM_NAMES])
SITES = ("r_elbow", "r_wrist", "l_elbow", "l_wrist")


def joint_targets(angles: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                  margin: float) -> np.ndarray:
    """Tracked angles ``(8,)`` clamped into DB's ranges shrunk by ``margin`` (rad)."""
    return np.clip(angles, lower + margin, upper - margin)


def arm_points(angles: np.ndarray, skeleton) -> np.ndarray:
    """``(T, 4, 3)`` elbows and wrists (:data:`SITES`) in the torso frame for arm angles
    ``(T, 8)`` on ``skeleton``."""
    q = np.zeros((len(angles), len(DOF_NAMES)))
    q[:, 6:] = angles
    _, p = segment_frames(q, skeleton)
    return p[:, [3, 4, 6, 7]]


class JointMimicStage(Stage):
    name = "mimic"

    def __init__(self, world, cfg):
        scene = world.scene
        self.world, self.cfg, self.scene = world, cfg, scene
        rate = cfg.servo_rate or world.scenario.timing.servo_rate
        self.every = int(round(world.scenario.timing.servo_rate / rate))
        self.dt = 1.0 / rate
        m = scene.model
        jid = scene.robot_joint_ids[JOINT_IDX]
        self.lower, self.upper = m.jnt_range[jid, 0].copy(), m.jnt_range[jid, 1].copy()
        self.q0 = scene.data.qpos[scene.robot_qpos].copy()
        self.q_cmd = self.q0[JOINT_IDX].copy()
        self.v_cmd = np.zeros(8)
        self.servo_out = Servo(m, scene.data, scene.robot_actuators, scene.robot_dof,
                               cfg.servo.feedforward)
        self.latest: np.ndarray | None = None
        self.t: list[float] = []
        self.q_robot: list[np.ndarray] = []
        self.q_target: list[np.ndarray] = []
        self._turns = Decimator(self.every)
        self._timer = None
        self.skeleton = db_skeleton(m, ROBOT_PREFIX)

    def attach(self, bus, timer) -> None:
        self._timer = timer
        bus.subscribe("poses", self._on_pose)

    def _on_pose(self, topic: str, msg) -> None:
        est = msg.value
        if self.cfg.tracker is not None and est.tracker != self.cfg.tracker:
            return
        if msg.t < self.cfg.start - 1e-9 or est.status != "tracking":
            return
        if all(n in est.angles for n in ARM_NAMES):
            self.latest = np.array([est.angles[n] for n in ARM_NAMES])

    def servo(self, t: float, bus) -> None:
        if self._turns() is not None:
            with self._timer.time(self.name):
                self._tick(t)

    def _tick(self, t: float) -> None:
        if self.latest is not None:
            target = joint_targets(self.latest, self.lower, self.upper,
                                   self.cfg.ik.limit_margin)
            a = min(1.0, self.cfg.interpolation.omega * self.dt)   # first-order low-pass
            q_new = self.q_cmd + a * (target - self.q_cmd)
            self.v_cmd = (q_new - self.q_cmd) / self.dt
            self.q_cmd = q_new
            self.t.append(t)
            self.q_target.append(target)
            self.q_robot.append(self.scene.data.qpos[self.scene.robot_qpos][JOINT_IDX].copy())
        q_d, v_d = self.q0.copy(), np.zeros(len(self.q0))
        q_d[JOINT_IDX], v_d[JOINT_IDX] = self.q_cmd, self.v_cmd
        self.servo_out.command(q_d, v_d, np.zeros(len(self.q0)))

    def metrics(self) -> dict:
        out: dict = {"mode": "joints", "ticks": len(self.t)}
        if self.t:
            gt = self.world.gt
            true = truth_angles(self.world, gt.index_of(np.asarray(self.t)))
            q = np.array(self.q_robot)
            err = np.degrees((q - true + np.pi) % (2 * np.pi) - np.pi)
            out["joint_rmse_deg"] = float(np.sqrt(np.mean(err ** 2)))
            out["joint_rmse_deg_per_dof"] = {n: float(np.sqrt(np.mean(err[:, k] ** 2)))
                                             for k, n in enumerate(ARM_NAMES)}
            d = arm_points(q, self.skeleton) - arm_points(true, self.skeleton)
            for k, s in enumerate(SITES):
                out[f"{s}_rmse_mm"] = 1e3 * rmse(d[:, k])
        return {"mimicry": {"joints": out}}
