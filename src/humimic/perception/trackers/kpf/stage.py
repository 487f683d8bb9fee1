"""The ``kpf`` tracker stage: one eye camera's ``frames`` -> ``poses`` (Schmidt et al.).

Started from the ground-truth pose at the first frame (the paper fits the model by hand), it
tracks every frame of its camera (set ``cameras.rate`` to the paper's 7.5 Hz) and publishes a
:class:`~humimic.messages.PoseEstimate` in the robot base frame stamped with the frame's photon
time, ready ``latency`` after it. Compute time (cue maps + filter, rendering excluded) goes to
``stages.<name>`` and ``trackers.<name>.frames_per_s`` (wall clock; ``frames_per_cpu_s`` per second
of the thread's CPU time, what a free core gives). Rerun: the best mode's back-projected
limbs and the heaviest mean-shift modes' forearms over the image, the model's skeleton beside
the avatar in 3-D.
"""

from __future__ import annotations

import time

import numpy as np

from humimic import bodymodel as bm
from humimic.messages import PoseEstimate
from humimic.perception.cues.auto_colors import look_alike_report
from humimic.perception.trackers.common import pose_error_plot
from humimic.perception.trackers.kpf.fovea import FovealLikelihood
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.scores import ENDPOINTS, KpfRecord, errors, kpf_metrics
from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
from humimic.perception.trackers.kpf.viz import log_frame, log_run
from humimic.perception.trackers.kpf.warmup import load_kernels
from humimic.pipeline.stage import Stage
from humimic.sensors.camera_model import invert_transform
from humimic.stamped import Stamped


class KpfStage(Stage):
    """See the module docstring."""

    def __init__(self, name: str, cfg, camera: str, world, skin_lut, rng, rlog=None,
                 frame_rate: float | None = None):
        self.name, self.cfg, self.camera, self.world = name, cfg, camera, world
        self.skin_lut, self.rlog = skin_lut, rlog
        self.body = kpf_body(world.scene.model)
        self.rng, self.frame_rate = rng, frame_rate
        self.tracker: KpfTracker | None = None
        self.rec = KpfRecord()
        self._bus = self._timer = None

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic: str, msg: Stamped) -> None:
        frame = msg.value.get(self.camera)
        if frame is None:
            return
        t = msg.t
        T_cam_base = invert_transform(frame.camera.T_base_cam)
        if self.tracker is None:                      # numba's kernels, outside the timing
            load_kernels(self.body, frame.camera.intrinsics, self.cfg, frame.image,
                         self.skin_lut, T_cam_base,
                         bm.truth_state(self.world, self.world.gt.index_of(t), "base"),
                         self.frame_rate)
        t0, c0 = time.perf_counter(), time.thread_time()
        maps = FrameCues(frame.image, self.skin_lut,     # computed where the particles look
                         colour_gradients=self.cfg.colour_gradients)
        fov = self._fovea(msg.value)
        if self.tracker is None:
            self.tracker = KpfTracker(self.body, frame.camera.intrinsics, self.cfg, self.rng,
                                      self.frame_rate, self._likelihood(frame, fov))
        if isinstance(self.tracker.lik, FovealLikelihood):
            q_ref = self.tracker.mode if self.tracker.mode is not None else \
                bm.truth_state(self.world, self.world.gt.index_of(t), "base")
            self.tracker.lik.look_views([None if f is None else f[1:] for f in fov], q_ref,
                                        self.cfg.fovea.in_view_margin_px, self.tracker.mode_prev)
        if self.tracker.mode is None:
            self.tracker.start(bm.truth_state(self.world, self.world.gt.index_of(t), "base"),
                               maps, T_cam_base)
        res = self.tracker.step(maps, T_cam_base)
        dt, cpu = time.perf_counter() - t0, time.thread_time() - c0
        self._timer.add(self.name, dt)
        pose = self.body.forward(res.mode[None])
        ends = {j: pose.joint(j)[0] for j in ENDPOINTS}
        state = "lost" if res.lost else "tracking"
        q_true = bm.truth_state(self.world, self.world.gt.index_of(t), "base")
        ll = self.tracker.lik.evaluate(np.stack([q_true, res.mode]), maps, T_cam_base).log_lik
        self.rec.add(t, res.mode, ends, res.lost, dt, cpu, res.iterations, T_cam_base,
                     float(ll[0] - ll[1]))
        angles = {n: float(v) for n, v in zip(bm.DOF_NAMES, res.mode, strict=True)
                  if n not in bm.TORSO_DOFS}
        est = PoseEstimate(self.name, "kpf", res.mode, bm.DOF_NAMES, np.diag(res.spread ** 2),
                           ends, angles, state)
        self._bus.publish("poses", Stamped(t, est, msg.t_ready + self.cfg.latency))
        if self.rlog is not None and self.rlog.enabled:
            log_frame(self.rlog, self.name, self.camera, t, self.body, frame, T_cam_base, res,
                      self.world.gt.T_world_frame("base"))

    def _fovea(self, frames: dict) -> list:
        """Per ``fovea`` camera ``(frame, maps, T_cam_base)`` of its frame, or None (no frame);
        empty without ``fovea``."""
        out = []
        for name in () if self.cfg.fovea is None else self.cfg.fovea.names:
            f = frames.get(name)
            out.append(None if f is None else (
                f, FrameCues(f.image, self.skin_lut, colour_gradients=self.cfg.colour_gradients),
                invert_transform(f.camera.T_base_cam)))
        return out

    def _likelihood(self, frame, fov: list):
        """The tracker's likelihood: the default, or with the foveal views (``fovea``; all
        their frames there at the first frame)."""
        if self.cfg.fovea is None or not fov or any(f is None for f in fov):
            return None
        c = self.cfg.fovea
        return FovealLikelihood(self.body, frame.camera.intrinsics, self.cfg,
                                [f[0].camera.intrinsics for f in fov], tuple(c.parts), c.weight,
                                c.use, c.decision_weight, c.moving_mm / 1000.0, c.skin_in_view)

    def metrics(self) -> dict:
        return {"trackers": {self.name: {
            **kpf_metrics(self.rec, self.world, self.body, self.camera),
            **look_alike_report(self.skin_lut.look_alike, self.skin_lut.class_lost)}}}

    def log(self, rlog) -> None:
        log_run(rlog, self.name, self.rec, self.world, self.body)

    def plots(self, out_dir) -> list:
        """``tracker_<name>.png``: the wrist error (whole, image plane, depth, to the nearest
        kinematic flip) and the elbow's."""
        if not self.rec.t:
            return []
        e, t = errors(self.rec, self.world, self.body), np.asarray(self.rec.t)
        return pose_error_plot(out_dir, self.name, {
            "wrist": (t, e["wrist"]), "wrist, image plane": (t, e["lateral"]),
            "wrist, depth": (t, e["depth"]), "wrist, flips forgiven": (t, e["flip_free"]),
            "elbow": (t, e["elbow"])})
