"""The SLAM stage: ``imu`` + ``headcam`` -> ``head_pose`` (Sugiyama & Miura sec. III).

The estimator (:class:`~humimic.estimation.ekf.estimator.WearableSlam`) runs on the head IMU's
samples and the head camera's frames in time order; after each it publishes a
:class:`~humimic.messages.HeadPose` stamped with that sample's time (ready ``latency`` later).
It starts where the wearer starts (the true head pose at the first frame plus a seeded error of
``init_position_std``, orientation from the IMU) with the screen's four corners as known
features, their patches cut where the start pose projects them.

The filter's inertial noises default to the head IMU's own error model (``sensors.imu``;
:mod:`~humimic.estimation.ekf.sensor_noise`): the orientation sensor's slowly varying errors
as their white equivalent, the accelerometer's white noise and bias walk as configured.

Scores (``metrics.json`` ``slam``), per head-camera frame against the ground-truth pose of the
head camera (frame I) in the paper's W:

* ``ate_rmse_m`` -- position error, no alignment (the screen fixes the frame);
  ``horizontal_rmse_m`` (x, z: Table II's), ``vertical_rmse_m``, ``position_max_error_m``;
* ``ate_se3_rmse_m``, ``ate_sim3_rmse_m`` (and ``sim3_scale``) -- the same after the best rigid
  (similarity) alignment; the Sim(3) ones None when the wearer's head did not move (its scale is
  undetermined); ``rpe_rmse_m`` -- relative translation error over ``rpe_delta_frames``
  frames, 1 s at the head camera's rate (:mod:`humimic.maths.trajectory`, evo's conventions);
* ``heading_rmse_deg`` (the optical axis about W's vertical), ``rotation_rmse_deg``;
* ``features_per_frame`` (measured), ``features_predicted_per_frame``,
  ``frames_without_features`` (and ``_fraction``), ``map_size_mean``, features added /
  deleted / converted to XYZ, ``features_added_on_arm`` (initialised inside the arm mask,
  which is computed whether or not ``mask_arm`` uses it: 0 when it does);
* ``cycle_ms`` -- the mean estimator cycle per frame: the IMU updates since the previous frame,
  the arm mask, undistortion, active search, the EKF update, map management and detection
  (rendering and the recording excluded; wall time, so it includes whatever else the machine
  does), and ``cycle_cpu_ms``, the same in the estimator thread's CPU time;
* ``position_nees_mean`` and its fraction in the 95 % chi-square band (3 dof).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf import sensor_noise
from humimic.estimation.ekf.arm_mask import ArmMaskParams
from humimic.estimation.ekf.estimator import EstimatorSettings, FrameReport, WearableSlam
from humimic.estimation.ekf.frontend import FAILED, MEASURED, NOT_SELECTED, FrontendParams
from humimic.estimation.ekf.slam import SlamParams
from humimic.estimation.ekf.slam_record import SlamRecord, slam_metrics
from humimic.messages import HeadPose
from humimic.motion import quat
from humimic.pipeline.stage import Stage
from humimic.scenario.base import pass_through
from humimic.sensors.camera_model import CameraImage, CameraModel, make_transform
from humimic.sensors.config import HeadInertial
from humimic.world.frames import GRAVITY_W, R_CV_I, SCREEN_CORNERS_W

#: Fig. 7's colours: measured red, failed blue, not selected green.
STATUS_COLORS = {MEASURED: (230, 30, 30), FAILED: (40, 80, 255), NOT_SELECTED: (40, 200, 60)}
SLAM = "world/W/slam"


def settings_from_config(cfg, imu=None) -> EstimatorSettings:
    """The estimator's settings from a scenario's ``slam`` section; ``imu`` the head IMU's
    section (``sensors.imu``, default its defaults) for the noises set to ``sensor``."""
    nz = cfg.noise
    imu = HeadInertial() if imu is None else imu
    if nz.orientation_std_deg == "sensor":
        orient = sensor_noise.orientation_tilt_yaw(imu)
    else:
        orient = (None if nz.orientation_std_deg is None
                  else tuple(np.radians(nz.orientation_std_deg)))
    # gravity turned by the orientation sensor's tilt error reaches the acceleration only
    # when the reading is rotated into W with it
    g = float(np.linalg.norm(GRAVITY_W)) if cfg.accel_frame == "W" else 0.0
    s_acc = (sensor_noise.accel_std_W(imu, g) if nz.sigma_accel == "sensor"
             else nz.sigma_accel)
    s_bias = (sensor_noise.accel_bias_drift_W(imu, g) if nz.accel_bias_drift == "sensor"
              else nz.accel_bias_drift)
    slam = replace(pass_through(SlamParams, nz),  # sigma_accel, sigma_gyro, sigma_px
                   noise=mm.MotionNoise(nz.jerk, nz.angular_acc, s_bias),
                   orientation_tilt_yaw=orient, sigma_accel=s_acc,
                   rho0=1.0 / cfg.init_depth, sigma_rho=cfg.init_inverse_depth_std)
    fe = pass_through(FrontendParams, cfg)  # patch_px, search_sigma, max_search_px, min_zncc
    return EstimatorSettings(use_camera=cfg.mode != "inertial", use_accel=cfg.mode != "camera",
                             use_gyro=cfg.use_gyro and cfg.mode != "camera",
                             use_orientation=cfg.use_orientation and cfg.mode != "camera",
                             accel_in_sensor_frame=cfg.accel_frame == "I",
                             target_features=cfg.target_features, max_map=cfg.max_map,
                             max_measured=cfg.max_measured, slam=slam, frontend=fe)


class SlamStage(Stage):
    name = "slam"

    def __init__(self, cfg, world, rng: np.random.Generator, rlog=None, mask_params=None,
                 image_every: int = 1):
        self.cfg, self.world, self.rng, self.rlog = cfg, world, rng, rlog
        self.settings = settings_from_config(cfg, world.scenario.sensors.imu)
        self.mask_params = mask_params or ArmMaskParams()
        self.image_every = image_every
        self.record = SlamRecord()
        self.slam: WearableSlam | None = None
        self._bus = self._timer = None
        self._frames = 0

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("imu", self._on_imu)
        bus.subscribe("headcam", self._on_frame)

    # ---- start -----------------------------------------------------------------------------
    def _start(self, t: float, intr, R_W_I: np.ndarray | None) -> None:
        """Start at the wearer's start: the true head position plus a seeded error of
        ``init_position_std``; the orientation the IMU reads (in camera-only mode, the true
        one with a seeded 0.5 deg error: the wearer faces the screen)."""
        gt, rng = self.world.gt, self.rng
        k = gt.index_of(t)
        p0 = gt.position("headcam", "W")[k] + self.cfg.init_position_std * rng.standard_normal(3)
        if R_W_I is None:
            R_W_I = gt.rotation("headcam", "W")[k] @ quat.to_matrix(
                quat.from_rotvec(np.radians(0.5) * rng.standard_normal(3)))
        x0 = mm.initial_state(p=p0, q=mm.quat_from_matrix(R_W_I))
        var = np.r_[np.full(3, max(self.cfg.init_position_std, 1e-3) ** 2),
                    np.full(4, 0.01**2), np.full(3, 0.05**2), np.full(3, 0.1**2),
                    np.full(3, 0.5**2), np.full(3, 0.05**2)]
        self.slam = WearableSlam(t, x0, np.diag(var), intr, R_CV_I, GRAVITY_W,
                                 SCREEN_CORNERS_W, self.settings)

    def _start_calibration(self, t: float, intr) -> np.ndarray:
        """Where the screen's corners appear from the marked start (undistorted pixels, NaN
        outside the image): the wearer starts where the system was calibrated, so the known
        features' first image positions are known (not the pose's: the filter starts with the
        seeded position error and the IMU's orientation, which the corners then correct)."""
        T = self.world.gt.pose("headcam", "W")[self.world.gt.index_of(t)]
        p_cv = (SCREEN_CORNERS_W - T[:3, 3]) @ T[:3, :3] @ R_CV_I.T
        uv = intr.pinhole().project(p_cv)
        inside = ((uv[:, 0] >= 0) & (uv[:, 0] <= intr.width - 1) & (uv[:, 1] >= 0)
                  & (uv[:, 1] <= intr.height - 1))
        uv[~inside] = np.nan
        return uv

    # ---- inputs ----------------------------------------------------------------------------
    def _on_imu(self, topic: str, msg) -> None:
        if self.slam is None or self.cfg.mode == "camera":
            self._last_R = msg.value.R_W_sensor
            return
        with self._timer.time(self.name):
            self.slam.on_imu(msg.t, msg.value.accel, msg.value.R_W_sensor, msg.value.gyro)
        self._publish(msg, -1)

    def _on_frame(self, topic: str, msg) -> None:
        image: CameraImage = msg.value
        known_uv = None
        if self.slam is None:
            self._start(msg.t, image.camera.intrinsics, getattr(self, "_last_R", None))
            known_uv = self._start_calibration(msg.t, image.camera.intrinsics)
        camera = self.cfg.mode != "inertial"
        with self._timer.time(self.name):
            t0, c0 = time.perf_counter(), time.thread_time()
            mask = self.slam.frontend.arm_mask(image.image, self.mask_params) if camera else None
            mask_s, mask_cpu = time.perf_counter() - t0, time.thread_time() - c0
            report = self.slam.on_frame(msg.t, image.image,
                                        mask if self.cfg.mask_arm else None, known_uv)
            if self.cfg.mask_arm:
                report.cycle_s += mask_s  # masking is part of the estimator's cycle
                report.cycle_cpu_s += mask_cpu
        on_arm = 0
        if mask is not None and len(report.new_uv):  # how many new features sit on the arm
            u, v = np.rint(report.new_uv).astype(int).T
            on_arm = int(np.sum(mask[v.clip(0, mask.shape[0] - 1),
                                     u.clip(0, mask.shape[1] - 1)]))
        f = self.slam.filter
        self.record.add(msg.t, f.interface, f.P_interface, report, on_arm)
        self._publish(msg, report.n_measured)
        if self.rlog is not None and self.rlog.enabled:
            with self._timer.time("slam_viz"):
                self._log(msg.t, image, report)
        self._frames += 1

    def _publish(self, msg, measured: int) -> None:
        f = self.slam.filter
        x = f.interface
        pose = HeadPose(x[0:3].copy(), x[3:7].copy(), x[7:10].copy(), x[10:13].copy(),
                        x[13:16].copy(), f.P_interface.copy(), f.n_features, measured)
        self._bus.publish("head_pose", msg.then(pose, self.cfg.latency))

    # ---- recording -------------------------------------------------------------------------
    def _log(self, t: float, image: CameraImage, report: FrameReport) -> None:
        rl, f = self.rlog, self.slam.filter
        if self._frames == 0:
            rl.log_transform(t, "world/W", self.world.T_world_W, static=True)
        x = f.interface
        R_W_I = mm.rotmat(x[3:7])
        T_W_cam = make_transform(R_W_I @ R_CV_I.T, x[0:3])
        if self.image_every and self._frames % self.image_every == 0:
            grey = self.slam.frontend.undistort(image.image)
            cam = CameraModel("slam", f.intr, T_W_cam, T_W_cam)
            rl.log_camera_image(t, f"{SLAM}/camera", CameraImage(t, cam, np.dstack([grey] * 3)))
            if len(report.fids):
                colors = [STATUS_COLORS[int(s)] for s in report.status]
                rl.log_ellipses_2d(t, f"{SLAM}/camera/image/features", report.uv, report.S,
                                   n_sigma=self.settings.frontend.search_sigma, colors=colors)
        else:
            rl.log_transform(t, f"{SLAM}/camera", T_W_cam)
        ids, pts, covs = f.feature_points()
        if len(ids):
            known = np.isin(ids, self.slam.known)
            rl.log_ellipsoids_3d(t, f"{SLAM}/map/uncertainty", pts, covs, n_sigma=2.0,
                                 colors=[(255, 160, 0)] * len(ids))
            rl.log_points(t, f"{SLAM}/map/features", pts, radii=0.015,
                          colors=np.where(known[:, None], (20, 20, 20), (255, 120, 0)))
        if self._frames % 15 == 0:  # the paths so far (the last 30 s, decimated)
            self._log_paths(rl, t, self.trajectories(), last=900, step=3)
        k = self.world.gt.index_of(t)
        rl.log_points(t, f"{SLAM}/truth/head", self.world.gt.position("headcam", "W")[k],
                      colors=[40, 200, 40], radii=0.02)
        rl.log_ellipsoids_3d(t, f"{SLAM}/estimate/head", x[None, 0:3],
                             f.P_interface[None, 0:3, 0:3], colors=[(230, 30, 30)])

    def trajectories(self) -> dict[str, np.ndarray]:
        """Per frame: time, the estimated pose and its covariance, feature counts, cycle time,
        and the true head position and rotation in W (what ``slam.npz`` holds)."""
        arr = self.record.arrays()
        gt = self.world.gt
        k = gt.index_of(arr["t"]) if len(arr["t"]) else np.zeros(0, int)
        return {**arr, "p_true": gt.position("headcam", "W")[k],
                "R_true": gt.rotation("headcam", "W")[k]}

    def metrics(self) -> dict:
        tr = self.trajectories()
        return {"slam": slam_metrics(tr, tr["p_true"], tr["R_true"], self.cfg.mode)}

    @staticmethod
    def _log_paths(rl, t: float, tr: dict, last: int, step: int) -> None:
        keep = slice(max(0, len(tr["t"]) - last), None, step)
        rl.log_lines_3d(t, f"{SLAM}/trajectory", [tr["p"][keep], tr["p_true"][keep]],
                        colors=[(230, 30, 30), (40, 200, 40)], radii=0.008,
                        labels=["estimated", "true"])

    def log(self, rlog) -> None:
        """The whole estimated and true paths, and the errors and feature counts as series."""
        tr = self.trajectories()
        if rlog is None or not rlog.enabled or len(tr["t"]) == 0:
            return
        from humimic.estimation.ekf.slam_record import pose_errors
        from humimic.viz.rerun_log import SERIES

        self._log_paths(rlog, float(tr["t"][-1]), tr, last=len(tr["t"]), step=1)
        e = pose_errors(tr["p"], tr["q"], tr["p_true"], tr["R_true"])
        rlog.log_series(f"{SERIES}/slam/error", tr["t"],
                        np.c_[100 * np.linalg.norm(e["position"], axis=1),
                              np.degrees(np.abs(e["heading"]))],
                        names=["position error (cm)", "|heading error| (deg)"])
        rlog.log_series(f"{SERIES}/slam/features", tr["t"],
                        np.c_[tr["measured"], tr["predicted"], tr["map_size"]],
                        names=["measured", "predicted in view", "map"])

    def archive(self, out_dir) -> list:
        tr = self.trajectories()
        if len(tr["t"]) == 0:
            return []
        np.savez_compressed(out_dir / "slam.npz", **tr)
        return [out_dir / "slam.npz"]

    def plots(self, out_dir) -> list:
        from humimic.estimation.ekf.slam_plots import plot_table2, plot_trajectory
        from humimic.estimation.ekf.sugiyama_tables import standing_intervals, table2

        tr = self.trajectories()
        if len(tr["t"]) == 0:
            return []
        out = [plot_trajectory(out_dir / "slam_trajectory.png", tr)]
        motion = self.world.scenario.human.motion
        waypoints = [(w.t, w.at) for w in getattr(motion, "waypoints", None) or []]
        if getattr(motion, "frame", None) == "W" and waypoints:  # the paper's Table II
            rows = table2(tr, standing_intervals(waypoints))
            if rows:
                out.append(plot_table2(out_dir / "slam_table2.png", rows))
        return out
