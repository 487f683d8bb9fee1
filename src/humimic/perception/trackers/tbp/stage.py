"""The TBP pipeline stage: one eye image (+ the torso pose) -> eight arm angles on ``poses``;
scores against the avatar (``trackers.<name>.*``): ``joint_rmse_deg`` (all eight angles and
per DOF), ``elbow_rmse_mm``, ``wrist_rmse_mm`` (both arms pooled, 3-D, base frame),
``wrist_within_10cm_fraction``, the wrist error split into the camera's depth and its image
plane (``wrist_depth_rmse_mm``, ``wrist_image_plane_rmse_mm``), ``shoulder_rmse_mm`` (where
the torso placement put the shoulders) and ``torso_source`` (``truth`` is an oracle).

With ``torso: head`` the torso is placed from the latest ``head`` measurement on the bus
(upright, facing the robot: the paper's coarsely fronto-parallel torso with shoulders deduced
from the face); until one arrives the stage publishes ``searching``.
"""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from humimic.bodymodel.avatar import truth_state
from humimic.bodymodel.kinematics import DOF_NAMES, JOINT_SEGMENT, ypr_matrix
from humimic.maths.stats import rmse
from humimic.messages import PoseEstimate
from humimic.perception.trackers.common import GOOD, PoseTrackerStage
from humimic.perception.trackers.frame_cues import load_kernels
from humimic.perception.trackers.tbp.tracker import ARM_NAMES, TbpTracker
from humimic.viz.rerun_log import ESTIMATES, PIXEL_CENTRE_SHIFT, image_entity

JOINTS = ("r_shoulder", "r_elbow", "r_wrist", "l_shoulder", "l_elbow", "l_wrist")


def torso_from_head(p_head: np.ndarray, head_offset: np.ndarray) -> np.ndarray:
    """Torso pose ``(x y z yaw pitch roll)`` (base frame) of an upright person whose head
    centre is at ``p_head`` and who faces the robot (at the base origin); ``head_offset`` is
    the head centre in the torso frame."""
    yaw = math.atan2(-p_head[1], -p_head[0])
    R = ypr_matrix(np.array(yaw), np.array(0.0), np.array(0.0))
    return np.r_[p_head - R @ head_offset, yaw, 0.0, 0.0]


class TbpStage(PoseTrackerStage):
    kind = "tbp"

    def __init__(self, name: str, cfg, camera: str, body, lut, world, rng):
        super().__init__(name, cfg.latency)
        self.cfg, self.camera, self.world, self.rng = cfg, camera, world, rng
        self.tracker, self.skin_lut = TbpTracker(cfg, body, lut), lut
        load_kernels(lut, cfg.bins)          # the cue images' numba kernels, before frame one
        body.forward(np.zeros((1, len(body.free))))     # and the compiled forward kinematics
        head = body.part("head")
        self.head_offset = body.skeleton.neck + head.p_seg_part
        self.head: np.ndarray | None = None
        self.torsos: list = []
        self.means: list = []
        self.cams: list = []
        self.recorded: list | None = None
        """Set to a list to keep every frame's ``(t, frame, torso)`` (offline replays:
        ``benchmarks/diagnose_tbp.py``)."""

    def attach(self, bus, timer) -> None:
        super().attach(bus, timer)
        if self.cfg.torso == "head":
            bus.subscribe("measurements", self._on_measurements)

    def _on_measurements(self, topic: str, msg) -> None:
        m = msg.value.targets.get("head")
        if m is not None:
            self.head = np.asarray(m.p_base, float)

    def _torso(self, t: float) -> np.ndarray | None:
        if self.cfg.torso == "truth":                                   # ORACLE
            return truth_state(self.world, self.world.gt.index_of(t), "base")[:6]
        return None if self.head is None else torso_from_head(self.head, self.head_offset)

    def track(self, t: float, images: dict):
        frame, torso = images.get(self.camera), self._torso(t)
        if frame is None or torso is None:
            self.torsos.append(None)
            self.means.append(None)
            self.cams.append(None)
            return PoseEstimate(self.tracker_name, self.kind, np.full(8, np.nan), ARM_NAMES,
                                status="searching")
        if self.recorded is not None:
            self.recorded.append((t, frame, torso))
        mean, cov, ok = self.tracker.step(frame, torso, self.rng)
        self.torsos.append(torso)
        self.means.append(mean)
        self.cams.append(frame.camera)
        pose = self.tracker.body.forward(mean[None], fixed=torso)
        joints = {j: pose.joint(j)[0] for j in JOINTS}
        return PoseEstimate(self.tracker_name, self.kind, mean, ARM_NAMES, cov, joints,
                            dict(zip(ARM_NAMES, map(float, mean), strict=True)),
                            "tracking" if ok else "lost")

    def log(self, rlog) -> None:
        """The MMSE skeleton (shoulder, elbow, wrist per arm) over the camera image and in 3-D
        beside the avatar."""
        if rlog is None or not rlog.enabled:
            return
        base = f"{image_entity(self.camera)}/{self.tracker_name}"
        T = self.world.gt.T_world_base
        for t, mean, torso, cam in zip(self.times, self.means, self.torsos, self.cams,
                                       strict=True):
            if mean is None:
                continue
            pose = self.tracker.body.forward(mean[None], fixed=torso)
            arms = [np.stack([pose.joint(f"{s}_{j}")[0] for j in ("shoulder", "elbow", "wrist")])
                    for s in ("r", "l")]
            rlog.log(t, f"{base}/skeleton", rr.LineStrips2D(
                [cam.project_base(a) + PIXEL_CENTRE_SHIFT for a in arms], colors=GOOD, radii=1.0))
            rlog.log_lines_3d(t, f"{ESTIMATES}/{self.tracker_name}",
                              [a @ T[:3, :3].T + T[:3, 3] for a in arms], colors=GOOD,
                              radii=0.01)

    def _kalman(self, times, ticks, est) -> dict:
        from humimic.perception.trackers.tbp.kalman import (
            KALMAN_DOFS,
            kalman_end_stops,
            kalman_scores,
        )

        idx = [ARM_NAMES.index(n) for n in KALMAN_DOFS]
        lim = self.tracker.body.free_limits
        truth = truth_state(self.world, ticks, "base")[:, 6:][:, idx]
        kf, _ = kalman_end_stops(times, truth, lim.lower[idx], lim.upper[idx],
                                 math.radians(self.cfg.kalman_sigma_deg), self.cfg.kalman_b,
                                 np.random.default_rng(self.world.scenario.seed))
        return kalman_scores(kf, est[:, idx], truth, lim.lower[idx], lim.upper[idx])

    def _poses(self):
        """Over the frames with an estimate: their indices, ticks, the true state (T, 14), the
        estimate (T, 8) and the body model's poses of both (``p_true``, ``p_est``)."""
        use = [i for i, m in enumerate(self.means) if m is not None]
        if not use:
            return None
        ticks = self.world.gt.index_of(np.asarray(self.times)[use])
        truth = truth_state(self.world, ticks, "base")
        est = np.array([self.means[i] for i in use])
        body = self.tracker.body.with_free(DOF_NAMES)
        torsos = np.array([self.torsos[i] for i in use])
        return use, ticks, truth, est, body.forward(truth), body.forward(np.hstack([torsos, est]))

    def error_series(self) -> dict:
        """Each wrist's and elbow's 3-D error per frame (NaN where nothing was estimated)."""
        poses = self._poses()
        if poses is None:
            return {}
        use, _, _, _, p_true, p_est = poses
        t = np.asarray(self.times)
        out = {}
        for joint in ("r_wrist", "l_wrist", "r_elbow", "l_elbow"):
            err = np.full(len(t), np.nan)
            err[use] = np.linalg.norm(p_est.joint(joint) - p_true.joint(joint), axis=1)
            out[joint] = (t, err)
        return out

    def scores(self) -> dict:
        poses = self._poses()
        out = {"torso_source": "truth (oracle)" if self.cfg.torso == "truth" else "head",
               "restarts": self.tracker.restarts}
        w = self.tracker.weights
        if w is not None:
            out.update({"lambda_s": w["lambda_s"], "cluttered": w["cluttered"],
                        "first_edge_density": w["edge_density"],
                        "lambda_c": [float(v) for v in w["lambda_c"]]})
        if poses is None:
            return out
        use, ticks, truth, est, p_true, p_est = poses
        if self.cfg.kalman:
            out["kalman"] = self._kalman(np.asarray(self.times)[use], ticks, est)
        err = np.degrees((est - truth[:, 6:] + np.pi) % (2 * np.pi) - np.pi)
        def joint_err(name):
            return p_est.joint(name) - p_true.joint(name)
        elbow = np.vstack([joint_err("r_elbow"), joint_err("l_elbow")])
        wrist = np.vstack([joint_err("r_wrist"), joint_err("l_wrist")])
        shoulder = np.vstack([joint_err("r_shoulder"), joint_err("l_shoulder")])
        R_cam = np.array([self.cams[i].T_base_cam[:3, :3] for i in use] * 2)
        wrist_cam = np.einsum("nji,nj->ni", R_cam, wrist)            # camera frame, z = depth
        out.update({
            "joint_rmse_deg": float(np.sqrt(np.mean(err ** 2))),
            "joint_rmse_deg_per_dof": {n: float(np.sqrt(np.mean(err[:, k] ** 2)))
                                       for k, n in enumerate(ARM_NAMES)},
            "elbow_rmse_mm": 1e3 * rmse(elbow), "wrist_rmse_mm": 1e3 * rmse(wrist),
            "right_wrist_rmse_mm": 1e3 * rmse(joint_err("r_wrist")),
            "wrist_depth_rmse_mm": 1e3 * rmse(wrist_cam[:, 2:]),
            "wrist_image_plane_rmse_mm": 1e3 * rmse(wrist_cam[:, :2]),
            "shoulder_rmse_mm": 1e3 * rmse(shoulder),
            "wrist_within_10cm_fraction": float(np.mean(np.linalg.norm(wrist, axis=1) <= 0.1)),
        })
        return out


__all__ = ["JOINT_SEGMENT", "TbpStage", "torso_from_head"]
