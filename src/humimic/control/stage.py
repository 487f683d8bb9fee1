"""The mimic stage: latest estimates -> mapping -> Cartesian PD -> IK -> servos, and gaze.

Per servo tick (Ude & Atkeson, "Generation of humanoid motion from human motion"):

1. each mapped human target's latest estimate (``estimates`` topic) is interpolated to the servo
   rate by a Cartesian PD (:mod:`~humimic.control.interpolation`);
2. mapped to its robot site by relative motion at the site's scale (fitted to the reach, see
   :mod:`~humimic.control.mapping`) and clamped into the site's reachable shell;
3. the redundant IK moves the driven sites there while holding the eyes' base still
   (:mod:`~humimic.control.ik`);
4. gaze points the eyes at the gaze target (:mod:`~humimic.control.gaze`);
5. the position servos get the joint targets with feed-forward (:mod:`~humimic.control.servo`).

A site whose target has no estimate yet holds its start position. Scores are computed after the
run from :class:`~humimic.control.record.MimicRecord` (:mod:`humimic.metrics.mimicry_report`).
"""

from __future__ import annotations

import time

import numpy as np

from humimic.control.decimate import Decimator
from humimic.control.gaze import Gaze
from humimic.control.ik import MimicIK, build_robot_model, on_limit_band
from humimic.control.interpolation import CartesianInterpolator
from humimic.control.mapping import (
    REFLECTIONS,
    ScaleFit,
    arm_length,
    auto_scale,
    map_displacement,
    reach_shell,
)
from humimic.control.record import MimicRecord
from humimic.control.servo import Servo
from humimic.messages import TargetEstimate
from humimic.motion.arm_ik import arm_lengths
from humimic.motion.avatar import AvatarGeometry
from humimic.pipeline.stage import Stage
from humimic.world.names import HUMAN_PREFIX, ROBOT_JOINTS

#: An estimate older than this (s) counts as lost: the command stops where it was.
MAX_AGE = 0.25
EYES = np.array([ROBOT_JOINTS.index(j) for j in ("L_EP", "L_ET", "R_EP", "R_ET")])
#: A human target's name among a tracker's pose joints (``PoseEstimate.joints``).
POSE_JOINT = {"right_hand": "r_hand", "left_hand": "l_hand", "right_elbow": "r_elbow",
              "left_elbow": "l_elbow", "right_wrist": "r_wrist", "left_wrist": "l_wrist"}
#: Joints of a driven arm whose limit band strains it (the wrists hardly move a palm).
STRAIN_JOINTS = ("SFE", "SAA", "HR", "EB")


class Channel:
    """One human target (optionally relative to another) driving one robot site."""

    def __init__(self, target: str, ref: str | None, site: str, p0_base_robot: np.ndarray,
                 M: np.ndarray, scale: float, shell, fit: ScaleFit | None):
        self.target, self.ref, self.site, self.M, self.shell = target, ref, site, M, shell
        self.scale = self.scale_initial = float(scale)
        self.fit = fit
        self.p0_robot = p0_base_robot.copy()
        self.p0_human: np.ndarray | None = None
        self.t0: float | None = None
        """Time at which the true human position is the mapping's origin."""
        self.last_used = None

    @property
    def started(self) -> bool:
        return self.p0_human is not None

    @property
    def S(self) -> np.ndarray:
        """The current ``s M``."""
        return self.scale * self.M

    def fit_scale(self, p_base_human: np.ndarray) -> float:
        """Update the scale (if fitted) for the human position of this tick; returns it."""
        if self.fit is not None:
            self.scale = self.fit.update(self.M @ (p_base_human - self.p0_human))
        return self.scale

    def to_robot(self, p_base_human: np.ndarray) -> np.ndarray:
        return map_displacement(p_base_human, self.p0_human, self.p0_robot, self.S)


class MimicStage(Stage):
    """Drives the robot from ``estimates`` (see the module docstring)."""

    name = "mimic"

    def __init__(self, world, cfg):
        sc, scene = world.scenario, world.scene
        self.world, self.cfg, self.scene = world, cfg, scene
        base_rate = sc.timing.servo_rate
        rate = cfg.servo_rate or base_rate
        self.every = int(round(base_rate / rate))
        self.dt = 1.0 / rate
        self.R_wb = scene.T_world_base[:3, :3].copy()
        self.p_wb = scene.T_world_base[:3, 3].copy()

        q0 = scene.data.qpos[scene.robot_qpos].copy()
        self.ik_model = build_robot_model(scene.opts.interocular)
        self.sites = list(cfg.map.values())
        self.ik = MimicIK(self.ik_model, q0, self.sites, cfg.ik, self.dt)
        p0_base = self.to_base(self.ik.site_positions())
        self.channels = [self._channel(target, site, p0_base[i])
                         for i, (target, site) in enumerate(cfg.map.items())]
        ic = cfg.interpolation
        other = "extrapolate" if ic.mode == "hold" else "hold"
        #: target -> (PD in the configured mode, PD in the other mode, for comparison)
        self.interps = {
            k: (CartesianInterpolator(ic.omega, ic.zeta, self.dt, ic.mode, MAX_AGE,
                                      ic.feedforward),
                CartesianInterpolator(ic.omega, ic.zeta, self.dt, other, MAX_AGE,
                                      ic.feedforward))
            for k in [*cfg.map, *([cfg.relative_to] if cfg.relative_to else [])]}
        self.wanted = set(cfg.targets)

        self.servo_out = Servo(scene.model, scene.data, scene.robot_actuators, scene.robot_dof,
                               cfg.servo.feedforward)
        g = cfg.gaze
        self.gaze = Gaze(scene, g.max_speed, self.dt) if g.enabled else None
        self.gaze_interp = CartesianInterpolator(ic.omega, ic.zeta, self.dt,
                                                 "extrapolate" if g.lead else "hold", MAX_AGE)
        self.scene_sites = np.array([scene.robot_site(s) for s in self.sites])
        self.head_site = scene.robot_site("eye_center")
        self.cams = np.array([scene.camera("L_wide"), scene.camera("R_wide")])

        phys_every = int(round(sc.timing.physics_rate / base_rate))
        n = world.n_ticks // (phys_every * self.every) + 2
        self.rec = MimicRecord(n, self.sites, len(ROBOT_JOINTS), self.dt)
        #: per channel: the shoulder and elbow joints whose limit bands count as strain
        self._strain_joints = [np.array([ROBOT_JOINTS.index(f"{s[0]}_{j}")
                                         for j in STRAIN_JOINTS]) for s in self.sites]
        self._strain_ranges = [self.ik_model.jnt_range[j] for j in self._strain_joints]
        self.latest: dict[str, tuple] = {}
        self.gaze_latest: tuple | None = None
        """``(t, TargetEstimate, t_ready)`` of the gaze target from ``gaze.tracker``."""
        self.v_prev = np.zeros(len(ROBOT_JOINTS))
        self._turns = Decimator(self.every)
        self._timer = None

    def _channel(self, target: str, site: str, p0_base: np.ndarray) -> Channel:
        """The mapping of ``target`` to ``site``: reflection, initial scale, shell and fit."""
        cfg = self.cfg
        scale = cfg.scale
        if scale == "auto":
            g = AvatarGeometry.from_model(self.scene.model, HUMAN_PREFIX)
            scale = auto_scale(arm_length(self.ik_model, site), *arm_lengths(g), site)
        shell = (reach_shell(self.ik_model, self.ik.q, site, self.scene.T_world_base)
                 if cfg.clamp_workspace else None)
        f = cfg.fit
        fit = (ScaleFit(scale, shell, p0_base, f.margin, f.time_constant, self.dt,
                        f.strain_rate) if f.enabled and shell is not None else None)
        return Channel(target, cfg.relative_to, site, p0_base, REFLECTIONS[cfg.mode], scale,
                       shell, fit)

    # ---- frames ---------------------------------------------------------------------------
    def to_base(self, p_world: np.ndarray) -> np.ndarray:
        return (p_world - self.p_wb) @ self.R_wb

    def to_world(self, p_base: np.ndarray) -> np.ndarray:
        return p_base @ self.R_wb.T + self.p_wb

    # ---- bus ------------------------------------------------------------------------------
    def attach(self, bus, timer) -> None:
        self._timer = timer
        bus.subscribe("estimates", self._on_estimates)
        bus.subscribe("measurements", self._on_measurements)
        if self.gaze is not None and self.cfg.gaze.tracker is not None:
            bus.subscribe("poses", self._on_pose)

    def _on_estimates(self, topic: str, msg) -> None:
        for target, est in msg.value.targets.items():
            if target in self.wanted:
                self.latest[target] = (msg.t, est, msg.t_ready)
                self.rec.estimates[target].add(msg.t, msg.t_ready, est.p_base)

    def _on_pose(self, topic: str, msg) -> None:
        """The gaze target from a tracker's pose (``gaze.tracker``) while it tracks."""
        g, est = self.cfg.gaze, msg.value
        joints = [POSE_JOINT.get(n, n) for n in (g.target, g.midpoint_with) if n is not None]
        if est.tracker == g.tracker and est.status == "tracking" and all(
                j in est.joints for j in joints):
            z = np.zeros(3)
            p = np.mean([est.joints[j] for j in joints], axis=0)   # ``midpoint_with``
            self.gaze_latest = (msg.t, TargetEstimate(g.target, p, z, z), msg.t_ready)

    def _on_measurements(self, topic: str, msg) -> None:
        for target, meas in msg.value.targets.items():
            if target in self.wanted:
                self.rec.measurements[target].add(msg.t, msg.t_ready, meas.p_base)

    # ---- servo ----------------------------------------------------------------------------
    def servo(self, t: float, bus) -> None:
        if self._turns() is None:
            return
        t0 = time.perf_counter()
        self._tick(t)
        self._timer.add(self.name, time.perf_counter() - t0)

    def _interpolate(self, t: float) -> dict:
        """Step each target's PDs to ``t + dt``: ``{target: (p, p_alt, t_est, est, t_ready)}``
        for the targets that have started (the first estimate at or after ``mimic.start``)."""
        out = {}
        for target, (pd, alt) in self.interps.items():
            latest = self.latest.get(target)
            if latest is None or (not pd.started and latest[0] < self.cfg.start - 1e-9):
                continue
            t_est, est, t_ready = latest
            age = t - t_est  # the PD's state is at t; it steps to t + dt
            if not pd.started:
                pd.start(est.p_base, est.v_base, est.a_base, age)
                alt.start(est.p_base, est.v_base, est.a_base, age)
            p = pd.step(est.p_base, est.v_base, est.a_base, age)
            p_alt = alt.step(est.p_base, est.v_base, est.a_base, age)
            out[target] = (p, p_alt, t_est, est, t_ready)
        return out

    def _commands(self, t: float, k: int) -> np.ndarray:
        rec = self.rec
        state = self._interpolate(t)
        p_base = np.empty((len(self.channels), 3))
        for i, ch in enumerate(self.channels):
            s = state.get(ch.target)
            r = state.get(ch.ref) if ch.ref else None
            if s is None or (ch.ref and r is None):
                p_base[i] = ch.p0_robot
                continue
            p_h, p_alt, t_est, est, t_ready = s
            p_est = est.p_base
            if r is not None:
                p_h, p_alt, p_est = p_h - r[0], p_alt - r[1], p_est - r[3].p_base
            if not ch.started:  # the paper's "initial position of a tracked human body part"
                ch.p0_human = np.array(p_est, float)
                ch.t0 = t_est
            rec.scale[k, i] = ch.fit_scale(p_h)
            p_cmd, p_cmd_alt = ch.to_robot(p_h), ch.to_robot(p_alt)
            rec.p_cmd_raw[k, i] = p_cmd
            if ch.shell is not None:
                p_cmd, rec.clamped[k, i] = ch.shell.clamp(p_cmd)
                p_cmd_alt, _ = ch.shell.clamp(p_cmd_alt)
            p_base[i] = p_cmd
            rec.p_cmd_alt[k, i] = p_cmd_alt
            rec.p_est[k, i] = ch.to_robot(p_est)
            rec.t_est[k, i] = t_est
            rec.t_ready[k, i] = t_ready
            rec.lost[k, i] = t - t_est > MAX_AGE
            rec.active[k, i] = True
            if ch.last_used is not est:
                ch.last_used = est
                rec.first_use[ch.target].extend((t_est, t_ready, t))
        rec.p_cmd[k] = p_base
        return p_base

    def _gaze(self, t: float, q_d: np.ndarray, v_d: np.ndarray, a_d: np.ndarray) -> None:
        """Overwrite the eyes' entries of the joint targets with the gaze law's."""
        latest = (self.gaze_latest if self.cfg.gaze.tracker is not None
                  else self.latest.get(self.cfg.gaze.target))
        gi = self.gaze_interp
        if latest is None:
            q_eyes, qdot_eyes = self.gaze.q, np.zeros(4)
        else:
            t_est, est, _ = latest
            age = t - t_est
            if not gi.started:
                gi.start(est.p_base, est.v_base, est.a_base, age)
            p = gi.step(est.p_base, est.v_base, est.a_base, age)
            q_eyes, qdot_eyes = self.gaze.step(self.to_world(p))
        q_d[EYES], v_d[EYES], a_d[EYES] = q_eyes, qdot_eyes, 0.0

    def _tick(self, t: float) -> None:
        rec, scene = self.rec, self.scene
        d = scene.data
        k = rec.n
        rec.t[k] = t
        p_base = self._commands(t, k)
        t0 = time.perf_counter()
        q, v = self.ik.step(self.to_world(p_base))
        rec.ik_s[k] = time.perf_counter() - t0
        a = (v - self.v_prev) / self.dt
        self.v_prev = v
        # The servo holds ctrl over [t, t + dt] while the IK's reference moves from q(t) to
        # q(t + dt): aim at the interval's middle so the servo neither lags nor leads.
        q_d, v_d = q - 0.5 * self.dt * v, v.copy()
        if self.gaze is not None:
            self._gaze(t, q_d, v_d, a)
        rec.ctrl[k] = self.servo_out.command(q_d, v_d, a)
        rec.q_ik[k], rec.qdot_ik[k] = q_d, v_d
        rec.p_ik[k] = self.to_base(self.ik.site_positions())
        self._strain(k, q)
        rec.p_robot[k] = self.to_base(d.site_xpos[self.scene_sites])
        rec.q_robot[k] = d.qpos[scene.robot_qpos]
        rec.p_head[k] = d.site_xpos[self.head_site]
        rec.R_head[k] = d.site_xmat[self.head_site]
        rec.cam_pos[k] = d.cam_xpos[self.cams]
        rec.cam_mat[k] = d.cam_xmat[self.cams]
        rec.n = k + 1

    def _strain(self, k: int, q: np.ndarray) -> None:
        """Tell each fitted channel whether its arm was strained this tick: the IK missed the
        command by more than ``fit.tolerance`` or a shoulder or elbow joint is on its band."""
        rec, f = self.rec, self.cfg.fit
        miss = np.linalg.norm(rec.p_ik[k] - rec.p_cmd[k], axis=1)
        for i, ch in enumerate(self.channels):
            if ch.fit is not None and rec.active[k, i]:
                j = self._strain_joints[i]
                ch.fit.strain(bool(miss[i] > f.tolerance or np.any(on_limit_band(
                    q[j], self._strain_ranges[i], self.cfg.ik.limit_margin))))

    # ---- results --------------------------------------------------------------------------
    def metrics(self) -> dict:
        from humimic.metrics.mimicry_report import mimic_metrics

        return mimic_metrics(self)

    def log(self, rlog) -> None:
        from humimic.viz.mimicry import log_mimicry

        log_mimicry(self, rlog)

    def plots(self, out_dir) -> list:
        from humimic.viz.mimicry import mimic_plots

        return mimic_plots(self, out_dir)
