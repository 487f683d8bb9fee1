"""The command stage: the wearer's estimated head and arm -> ``commands`` (Sugiyama sec. V-C).

At ``commands.rate`` it takes the latest head pose (the SLAM's ``head_pose`` or the ground
truth) and Wii-remote pose (the arm EKF's ``arm_pose`` or the truth), turns them into the
targets of :mod:`humimic.control.commands` and issues a :class:`~humimic.messages.RobotCommand`
of a kind when the previous one of that kind has finished (``command_done``, from the follower)
and the target has moved past the kind's threshold. The robot's state at t = 0 is where the
thresholds are first measured from.
"""

from __future__ import annotations

import numpy as np

from humimic.control import commands as cmds
from humimic.control.decimate import Decimator
from humimic.control.follow import PAN, TILT
from humimic.estimation.ekf.arm_record import truth_in_head
from humimic.estimation.ekf.head_track import OracleHeadTrack, SlamHeadTrack
from humimic.messages import RobotCommand
from humimic.pipeline.stage import Stage
from humimic.stamped import Stamped


class CommandStage(Stage):
    """Issues ``commands``; see the module docstring."""

    name = "commands"

    def __init__(self, world, cfg, rlog=None):
        self.world, self.cfg, self.rlog = world, cfg, rlog
        scene = world.scene
        self.head = OracleHeadTrack(world.gt) if cfg.head_pose == "oracle" else SlamHeadTrack()
        self.gate = cmds.CommandGate(cfg.thresholds())
        T0 = scene.T_world_base
        d = scene.data
        self.p_eyes_base = (d.site_xpos[scene.robot_site("eye_center")] - T0[:3, 3]) @ T0[:3, :3]
        palm0 = (d.site_xpos[scene.robot_site("R_palm")] - T0[:3, 3]) @ T0[:3, :3]
        starts = {"move": np.zeros(2), "head": d.qpos[scene.robot_qpos[[PAN, TILT]]].copy(),
                  "arm": palm0}
        for kind in cfg.kinds:
            self.gate.start(kind, starts[kind])
        self.every = max(1, int(round(world.scenario.timing.servo_rate / cfg.rate)))
        self.p_start_W: np.ndarray | None = None
        self.arm: tuple[float, np.ndarray] | None = None
        """Latest (t, p_A^I)."""
        self.issued: list[tuple[float, float, RobotCommand]] = []
        """``(source time, issue time, command)``."""
        self.targets: list[tuple[float, dict]] = []
        """``(t, {kind: target})`` at every check (the commands' would-be targets)."""
        self.seq = dict.fromkeys(cmds.KINDS, 0)
        self._turns = Decimator(self.every)
        self._bus = self._timer = None
        self.follower = None
        """The :class:`~humimic.control.follow.FollowStage` (read after the run, for the
        report only)."""

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("command_done", lambda topic, msg: self.gate.done(msg.value.kind))
        if isinstance(self.head, SlamHeadTrack):
            bus.subscribe("head_pose", lambda topic, msg: self.head.add(msg.t, msg.value))
        if self.cfg.arm_pose == "ekf" and "arm" in self.cfg.kinds:
            bus.subscribe("arm_pose", self._on_arm)

    def _on_arm(self, topic: str, msg: Stamped) -> None:
        self.arm = (msg.t, np.asarray(msg.value.p_I, float))

    def _latest_arm(self, t: float) -> tuple[float, np.ndarray] | None:
        if self.cfg.arm_pose == "oracle":
            return t, truth_in_head(self.world.gt, np.array([t]))[0][0]  # at its nearest tick
        return self.arm

    def servo(self, t: float, bus) -> None:
        if self._turns() is None:
            return
        with self._timer.time(self.name):
            self._check(t)

    def _check(self, t: float) -> None:
        t_head = min(t, self.head.ready_until())
        if not np.isfinite(t_head):
            return
        head = self.head.at(t_head)
        if self.p_start_W is None:
            self.p_start_W = head.p_W.copy()
        targets = {"move": (t_head, cmds.movement_target(head.p_W, self.p_start_W)),
                   "head": (t_head, cmds.head_angles(head.R_W_I))}
        arm = self._latest_arm(t) if "arm" in self.cfg.kinds else None
        if arm is not None:
            t_arm, p_A = arm
            R = self.head.at(min(t_arm, self.head.ready_until())).R_W_I
            targets["arm"] = (t_arm, cmds.arm_target(p_A, R, self.p_eyes_base))
        self.targets.append((t, {k: v[1] for k, v in targets.items()}))
        for kind in self.cfg.kinds:
            if kind in targets and self.gate.offer(kind, targets[kind][1]):
                self._issue(t, targets[kind][0], kind, targets[kind][1])

    def _issue(self, t: float, t_source: float, kind: str, target: np.ndarray) -> None:
        cmd = RobotCommand(kind, np.asarray(target, float).copy(), t, self.seq[kind])
        self.seq[kind] += 1
        self.issued.append((t_source, t, cmd))
        self._bus.publish("commands", Stamped(t_source, cmd, t))
        if self.rlog is not None:
            text = np.array2string(cmd.target, precision=3, separator=", ")
            self.rlog.log_text(t, "events/commands", f"{kind} #{cmd.seq}: {text}")

    # ---- results --------------------------------------------------------------------------
    def metrics(self) -> dict:
        from humimic.control.commands_report import commands_metrics

        return commands_metrics(self, self.follower) if self.follower is not None else {}

    def plots(self, out_dir) -> list:
        from humimic.control.commands_report import commands_plot

        if self.follower is None:
            return []
        return commands_plot(self, self.follower, out_dir / "commands.png")

    def log(self, rlog) -> None:
        """The robot's base path, its move targets and the wearer's path (world, on the
        floor) in the rerun recording."""
        rl = rlog
        if self.follower is None:
            return
        rec = self.follower.rec.arrays()
        if rl is None or not rl.enabled or len(rec["t"]) == 0:
            return
        T0 = self.world.scene.T_world_base

        def floor(xy):
            p = np.column_stack([xy[:, 0], xy[:, 1], np.zeros(len(xy))]) @ T0[:3, :3].T
            p[:, :2] += T0[:2, 3]
            p[:, 2] = 0.01
            return p
        t_end = float(rec["t"][-1])
        rl.log_lines_3d(t_end, "world/robot/base_path", [floor(rec["base"][:, :2])],
                        colors=[[220, 50, 50]], labels=["robot base"])
        moves = [c.target for _, _, c in self.issued if c.kind == "move"]
        if moves:
            pts = floor(np.vstack([np.zeros(2)] + moves))
            rl.log_lines_3d(t_end, "world/robot/commanded_path", [pts], colors=[[240, 160, 40]],
                            labels=["commanded"])
            rl.log_points(t_end, "world/robot/move_targets", pts[1:], colors=[[240, 160, 40]],
                          radii=0.04)
        p = self.world.gt.p_world("headcam")[::28]
        p = p.copy()
        p[:, 2] = 0.01
        rl.log_lines_3d(t_end, "world/truth/wearer_path", [p], colors=[[40, 40, 40]],
                        labels=["wearer"])
