"""The robot carrying out the ``commands`` (Sugiyama & Miura sec. V-C): the mobile base through
the world's :class:`~humimic.control.base.BaseController` (at most 0.4 m/s), the head's pan
and tilt (``B_HR``, ``B_HN``) at a limited speed, the right palm through the mink IK
(:class:`~humimic.control.ik.MimicIK`, the head's angles its posture targets). Head and palm
move to a new target along a minimum-jerk path whose peak speed is the configured one (a step
would saturate the IK's joint speeds and shake the head on its servos). When a command has
finished it is published on ``command_done`` (the command stage issues the next of its kind
only then).

The IK runs on the robot model alone, whose base stays at the start pose: arm targets are in
the robot's base frame, which moves with the base, so the IK's world is the base frame at t = 0.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from humimic.control.decimate import Decimator
from humimic.control.ik import MimicIK, build_robot_model, posture_costs
from humimic.control.mapping import reach_shell
from humimic.control.servo import Servo
from humimic.motion.primitives import min_jerk
from humimic.pipeline.stage import Stage
from humimic.stamped import Stamped
from humimic.world.names import ROBOT_JOINTS, ROBOT_PREFIX

PAN, TILT = ROBOT_JOINTS.index("B_HR"), ROBOT_JOINTS.index("B_HN")
#: Posture cost pulling pan and tilt to their commanded angles (per rad).
HEAD_COST = 10.0
#: How often the robot's state is recorded (Hz).
RECORD_RATE = 30.0


@dataclass
class FollowRecord:
    """The robot's state and targets at :data:`RECORD_RATE`."""

    t: list = field(default_factory=list)
    base: list = field(default_factory=list)
    """(x, y, yaw) in R."""
    base_target: list = field(default_factory=list)
    head: list = field(default_factory=list)
    """(pan, tilt) of the robot, rad."""
    head_target: list = field(default_factory=list)
    palm: list = field(default_factory=list)
    """Right palm in the base frame (m)."""
    palm_target: list = field(default_factory=list)
    done: list = field(default_factory=list)
    """``(t, command)`` for each finished command."""

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.__dict__.items() if k != "done"}


@dataclass
class Segment:
    """A minimum-jerk move from ``start`` to ``end`` beginning at ``t0``, lasting ``duration``
    (s); the peak speed of a minimum-jerk move is 1.875 |end - start| / duration."""

    start: np.ndarray
    end: np.ndarray
    t0: float = 0.0
    duration: float = 0.0

    @classmethod
    def to(cls, start, end, t0: float, peak_speed: float, min_duration: float) -> Segment:
        start, end = np.asarray(start, float).copy(), np.asarray(end, float).copy()
        d = float(np.linalg.norm(end - start))
        return cls(start, end, t0, max(min_duration, 1.875 * d / peak_speed))

    def at(self, t: float) -> np.ndarray:
        if self.duration <= 0.0:
            return self.end.copy()
        return self.start + (self.end - self.start) * float(min_jerk((t - self.t0)
                                                                     / self.duration))


def base_pose(data, pelvis: int) -> np.ndarray:
    """4x4 pose of the robot's base (pelvis) in the world."""
    T = np.eye(4)
    T[:3, :3] = data.xmat[pelvis].reshape(3, 3)
    T[:3, 3] = data.xpos[pelvis]
    return T


class FollowStage(Stage):
    """Executes ``commands``; see the module docstring."""

    name = "follow"

    def __init__(self, world, cfg):
        self.world, self.cfg, scene = world, cfg, world.scene
        self.scene = scene
        servo_rate = world.scenario.timing.servo_rate
        self.every = max(1, int(round(servo_rate / min(cfg.rate, servo_rate))))
        self.dt = self.every / servo_rate
        q0 = scene.data.qpos[scene.robot_qpos].copy()
        model = build_robot_model(scene.opts.interocular)
        self.ik = MimicIK(model, q0, ["R_palm"], cfg.ik, self.dt)
        cost = posture_costs(cfg.ik.posture_cost, cfg.ik.torso_cost)
        cost[[PAN, TILT]] = HEAD_COST
        self.ik.posture_task.set_cost(cost)
        self.posture = self.ik.q.copy()
        self.T0 = scene.T_world_base.copy()
        """The base frame at t = 0: the IK's world."""
        self.shell = reach_shell(model, self.ik.q, "R_palm", self.T0)
        self.servo_out = Servo(scene.model, scene.data, scene.robot_actuators, scene.robot_dof,
                               "dynamics")
        self.pelvis = scene.model.body(ROBOT_PREFIX + "pelvis").id
        self.palm_site = scene.robot_site("R_palm")
        self.head_target = q0[[PAN, TILT]].copy()
        self.head_path = Segment(self.head_target, self.head_target)
        self.palm_target = self._to_base0(self.ik.site_positions()[0])
        self.palm_path = Segment(self.palm_target, self.palm_target)
        self._t = 0.0
        self.active: dict[str, object] = {}
        self._still_since: float | None = None
        self._palm_prev: np.ndarray | None = None
        self.v_prev = np.zeros(len(ROBOT_JOINTS))
        self.rec = FollowRecord()
        self._record_every = max(1, int(round(1.0 / (RECORD_RATE * self.dt))))
        self._settled = False
        self._turns = Decimator(self.every)
        self._bus = self._timer = None

    def _to_base0(self, p_world: np.ndarray) -> np.ndarray:
        return (p_world - self.T0[:3, 3]) @ self.T0[:3, :3]

    # ---- bus ------------------------------------------------------------------------------
    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("commands", self._on_command)

    def _on_command(self, topic: str, msg: Stamped) -> None:
        cmd = msg.value
        self._settled = False
        self.active[cmd.kind] = (cmd, msg.t_ready)
        if cmd.kind == "move":
            self.world.base.set_target(float(cmd.target[0]), float(cmd.target[1]), 0.0)
        elif cmd.kind == "head":
            lo, hi = self.scene.robot_range[[PAN, TILT]].T
            self.head_target = np.clip(cmd.target, lo + 0.02, hi - 0.02)
            self.head_path = Segment.to(self.head_path.at(self._t), self.head_target, self._t,
                                        self.cfg.head_speed, 0.1)
        elif cmd.kind == "arm":
            self.palm_target, _ = self.shell.clamp(np.asarray(cmd.target, float))
            self.palm_path = Segment.to(self.palm_path.at(self._t), self.palm_target, self._t,
                                        self.cfg.arm_speed, 0.2)
            self._still_since = None

    def _finish(self, t: float, kind: str) -> None:
        cmd, _ = self.active.pop(kind)
        self.rec.done.append((t, cmd))
        self._bus.publish("command_done", Stamped(t, cmd))

    # ---- servo ----------------------------------------------------------------------------
    def servo(self, t: float, bus) -> None:
        turn = self._turns()
        if turn is None:
            return
        t0 = time.perf_counter()
        self._t = t
        d = self.scene.data
        moving = (t <= self.head_path.t0 + self.head_path.duration
                  or t <= self.palm_path.t0 + self.palm_path.duration)
        if moving or not self._settled:  # an IK at rest with fixed targets stays where it is
            self.posture[[PAN, TILT]] = self.head_path.at(t + self.dt)
            self.ik.posture_task.set_target(self.posture)
            palm = self.palm_path.at(t + self.dt)
            q, v = self.ik.step((self.T0[:3, :3] @ palm + self.T0[:3, 3])[None])
            a = (v - self.v_prev) / self.dt
            self.v_prev = v
            self.servo_out.command(q - 0.5 * self.dt * v, v, a)
            self._settled = not moving and float(np.max(np.abs(v))) < 1e-3

        T_wb = base_pose(d, self.pelvis)
        palm = (d.site_xpos[self.palm_site] - T_wb[:3, 3]) @ T_wb[:3, :3]
        head = d.qpos[self.scene.robot_qpos[[PAN, TILT]]]
        self._check_done(t, palm, head)
        if turn % self._record_every == 0:
            r = self.rec
            r.t.append(t)
            base = self.world.base
            r.base.append(base.pose if base is not None else np.zeros(3))
            r.base_target.append(base.target.copy() if base is not None else np.zeros(3))
            r.head.append(head.copy())
            r.head_target.append(self.head_target.copy())
            r.palm.append(palm)
            r.palm_target.append(self.palm_target.copy())
        self._timer.add(self.name, time.perf_counter() - t0)

    def _check_done(self, t: float, palm: np.ndarray, head: np.ndarray) -> None:
        if "move" in self.active and self.world.base.arrived:
            self._finish(t, "move")
        tol = np.radians(self.cfg.head_tolerance_deg)
        if "head" in self.active and np.all(np.abs(head - self.head_target) <= tol):
            self._finish(t, "head")
        if "arm" in self.active:
            if np.linalg.norm(palm - self.palm_target) <= self.cfg.arm_tolerance:
                self._finish(t, "arm")
                return
            moving = (self._palm_prev is None
                      or np.linalg.norm(palm - self._palm_prev) > 0.01 * self.dt)
            self._palm_prev = palm
            if moving:
                self._still_since = None
            elif self._still_since is None:
                self._still_since = t
            elif t - self._still_since >= self.cfg.arm_settle_s:
                self._finish(t, "arm")

    def metrics(self) -> dict:
        return {}
