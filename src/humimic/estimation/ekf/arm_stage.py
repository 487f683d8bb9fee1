"""The arm stage: ``headcam`` + ``wiimote`` + the head pose -> ``arm_pose`` (Sugiyama sec. IV).

Each head-camera frame is searched for the marker's regions when it arrives; every Wii-remote
sample and frame then waits in time order until the head pose is known at its time (at once with
``head_pose: oracle``; with ``slam`` when the SLAM's ``head_pose`` for that instant has been
delivered) and goes through the filter: a Wii sample gives the gyro's rate relative to the head
(with the head's rate over the sample's interval) and, when the remote is still, its pitch and
roll; a frame gives the chosen marker region's centroid and area, and the estimate is published
on ``arm_pose`` stamped with the frame's time.
"""

from __future__ import annotations

import heapq
import itertools
import time

import mujoco
import numpy as np

from humimic.estimation.ekf.arm import ArmEKF, Marker
from humimic.estimation.ekf.arm_marker import MarkerBlob, marker_candidates
from humimic.estimation.ekf.arm_record import (
    ArmRecord,
    arm_errors,
    arm_metrics,
    arm_plot,
    truth_in_head,
)
from humimic.estimation.ekf.head_track import OracleHeadTrack, SlamHeadTrack
from humimic.messages import ArmPose
from humimic.pipeline.stage import Stage
from humimic.stamped import Stamped
from humimic.world.frames import from_frame
from humimic.world.names import HUMAN_PREFIX

MARKER_GEOM = HUMAN_PREFIX + "wiimote_marker"


def marker_from_model(model: mujoco.MjModel, geom: str = MARKER_GEOM) -> Marker:
    """The marker's shape from the scene: a sphere's radius, or a box's largest face as the
    paper's flat marker (corners in the remote's frame A, around the box's centre)."""
    g = model.geom(geom)
    if int(g.type[0]) == mujoco.mjtGeom.mjGEOM_SPHERE:
        return Marker(radius=float(g.size[0]))
    if int(g.type[0]) != mujoco.mjtGeom.mjGEOM_BOX:
        raise ValueError(f"marker geom {geom!r} must be a sphere or a box")
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, g.quat)
    R = R.reshape(3, 3)  # body (A) <- geom
    thin = int(np.argmin(g.size))
    a, b = (i for i in range(3) if i != thin)
    sa, sb = g.size[a], g.size[b]
    local = np.zeros((4, 3))
    local[:, a] = [-sa, sa, sa, -sa]
    local[:, b] = [-sb, -sb, sb, sb]
    return Marker(corners=local @ R.T)


def choose_marker(ekf: ArmEKF, t: float, cands: list[MarkerBlob], select: str,
                  start_depth: tuple[float, float]) -> MarkerBlob | None:
    """The region the filter takes at ``t``: to start, the largest whose area puts the marker
    within ``start_depth``; then the largest (``select: largest``, the paper) or the one the
    prediction makes most likely (``predicted``)."""
    if not cands:
        return None
    if ekf.needs_start(t):
        lo, hi = start_depth
        ok = [c for c in cands if lo <= ekf.marker.depth(c.area, ekf.K) <= hi]
        return ok[0] if ok else None
    if select == "largest" or len(cands) == 1:
        return cands[0]
    return cands[int(np.argmin(ekf.marker_nis(t, [(c.uv, c.area) for c in cands])))]


class ArmStage(Stage):
    """Estimates the Wii remote's pose in the head frame; see the module docstring."""

    name = "arm"

    def __init__(self, world, cfg, rlog=None):
        self.world, self.cfg, self.rlog = world, cfg, rlog
        self.K_image = world.head_rig.intrinsics("headcam")
        self.K = self.K_image.pinhole()
        self.ekf = ArmEKF(self.K, marker_from_model(world.scene.model), cfg.motion_noise(),
                          cfg.arm_noise(world.scenario.sensors), use_area=cfg.use_area,
                          pitch_roll=cfg.pitch_roll,
                          gate_prob=cfg.gate_prob, max_gap=cfg.max_gap,
                          max_rejected=cfg.max_rejected, static_tol_g=cfg.static_tol_g)
        self.marker_prm = cfg.marker.params()
        self.head = OracleHeadTrack(world.gt) if cfg.head_pose == "oracle" else SlamHeadTrack()
        self.rec = ArmRecord()
        self._queue: list = []
        self._seq = itertools.count()
        self._now = 0.0
        self._t_wii: float | None = None
        self._pending_s = 0.0
        self._bus = self._timer = None

    # ---- bus ------------------------------------------------------------------------------
    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("headcam", self._on_frame)
        bus.subscribe("wiimote", self._on_wii)
        if isinstance(self.head, SlamHeadTrack):
            bus.subscribe("head_pose", self._on_head)

    def _push(self, t: float, kind: str, value) -> None:
        heapq.heappush(self._queue, (t, next(self._seq), kind, value))

    def _on_frame(self, topic: str, msg: Stamped) -> None:
        t0 = time.perf_counter()
        cands = marker_candidates(msg.value.image, self.K_image, self.marker_prm)
        self._pending_s += time.perf_counter() - t0
        self._timer.add(self.name + "_marker", time.perf_counter() - t0)
        self._push(msg.t, "frame", cands)
        self._drain(msg.t_ready)

    def _on_wii(self, topic: str, msg: Stamped) -> None:
        self._push(msg.t, "wii", msg.value)
        self._drain(msg.t_ready)

    def _on_head(self, topic: str, msg: Stamped) -> None:
        self.head.add(msg.t, msg.value)
        self._drain(msg.t_ready)

    # ---- the filter -----------------------------------------------------------------------
    def _drain(self, now: float) -> None:
        self._now = now
        ready = self.head.ready_until()
        with self._timer.time(self.name):
            while self._queue and self._queue[0][0] <= ready:
                t, _, kind, value = heapq.heappop(self._queue)
                t0 = time.perf_counter()
                if kind == "wii":
                    self._wii(t, value)
                    self._pending_s += time.perf_counter() - t0
                else:
                    self._frame(t, value, t0)

    def _wii(self, t: float, reading) -> None:
        dt = 0.0 if self._t_wii is None else t - self._t_wii
        self._t_wii = t
        w_I = self.head.at(t - 0.5 * dt).w_I  # the head's rate over the sample's interval
        self.ekf.on_wii(t, reading.gyro, reading.accel, w_I, self.head.at(t).R_W_I)

    def _frame(self, t: float, cands: list[MarkerBlob], t0: float) -> None:
        ekf, head = self.ekf, self.head.at(t)
        blob = choose_marker(ekf, t, cands, self.cfg.marker.select, self.cfg.marker.start_depth)
        if blob is not None:
            ekf.on_marker(t, blob.uv, blob.area, head.R_W_I)
        elif ekf.initialized:
            ekf.predict(t)
        taken = ekf.t_marker == t  # started or updated with this frame's marker
        self._pending_s += time.perf_counter() - t0
        self.rec.add(t, ekf.x if ekf.initialized else None, ekf.P, taken, len(cands),
                     None if blob is None else blob.uv, head, self._pending_s)
        self._pending_s = 0.0
        if ekf.initialized:
            x = ekf.x
            pose = ArmPose(x[0:3].copy(), x[3:7].copy(), x[7:10].copy(), x[10:13].copy(),
                           ekf.P.copy(), taken)
            self._bus.publish("arm_pose", Stamped(t, pose, max(self._now, t) + self.cfg.latency))
            self._log(t, x, head, blob)

    # ---- outputs --------------------------------------------------------------------------
    def _log(self, t, x, head, blob) -> None:
        rl = self.rlog
        if rl is None or not rl.enabled:
            return
        T_world_W = self.world.T_world_W
        p_W = head.p_W + head.R_W_I @ x[0:3]
        rl.log_points(t, "world/estimates/wiimote", from_frame(T_world_W, p_W),
                      colors=[[230, 60, 60]], radii=0.015, labels=["Wii (arm EKF)"])
        p_true = self.world.gt.p_world("wiimote_marker")[self.world.gt.index_of(t)]
        rl.log_points(t, "world/truth/wiimote", p_true, colors=[[40, 40, 40]], radii=0.01)
        if blob is not None:
            rl.log_ellipses_2d(t, "world/cameras/headcam/image/marker", blob.uv_distorted,
                               np.eye(2) * blob.pixels / np.pi, n_sigma=1.0,
                               colors=[[255, 255, 0]])

    def metrics(self) -> dict:
        return arm_metrics(self.rec, self.world.gt, self.K, self.ekf)

    def plots(self, out_dir) -> list:
        return arm_plot(self.rec, self.world.gt, out_dir / "arm_position.png")

    def archive(self, out_dir) -> list:
        """``arm.npz``: per frame the state, its position covariance, whether the marker was
        taken, the chosen centroid, and the truth (marker centre in I, ``R_I_A``)."""
        a = self.rec.arrays()
        if len(a["t"]) == 0:
            return []
        p_true, R_true = truth_in_head(self.world.gt, a["t"])
        path = out_dir / "arm.npz"
        np.savez_compressed(path, t=a["t"], x=a["x"], P_p=a["P_p"], measured=a["measured"],
                            candidates=a["candidates"], uv=a["uv"], p_I_true=p_true,
                            R_I_A_true=R_true)
        return [path]

    def log(self, rlog) -> None:
        """Whole estimated and true Wii-remote trajectories (world), and the error series."""
        rl = rlog
        a = self.rec.arrays()
        if rl is None or not rl.enabled or len(a["t"]) == 0:
            return
        ok = np.all(np.isfinite(a["x"][:, 0:3]), axis=1)
        p_W = a["p_head_W"] + np.einsum("nij,nj->ni", a["R_head_W"], a["x"][:, 0:3])
        est = from_frame(self.world.T_world_W, p_W[ok])
        k = self.world.gt.index_of(a["t"])
        true = self.world.gt.p_world("wiimote_marker")[k]
        t_end = float(a["t"][-1])
        rl.log_lines_3d(t_end, "world/estimates/wiimote_path", [est], colors=[[230, 60, 60]],
                        labels=["Wii (arm EKF)"])
        rl.log_lines_3d(t_end, "world/truth/wiimote_path", [true], colors=[[40, 40, 40]],
                        labels=["Wii (true)"])
        e = arm_errors(self.rec, self.world.gt)
        err = e["err"][ok]
        rl.log_series("series/arm/error_cm", a["t"][ok],
                      100 * np.column_stack([err[:, 2], np.linalg.norm(err, axis=1)]),
                      names=["depth", "position"])
