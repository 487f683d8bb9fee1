"""The movement estimator of Sugiyama & Miura sec. III as one object: EKF + front end + map
management, fed the head IMU's samples and the head camera's frames in time order.

Per IMU sample (180 Hz): predict to its time, fuse the orientation (eq. 6), the angular rate
and the accelerometer's reading -- in its own frame by default
(:func:`~humimic.estimation.ekf.motion_model.h_specific_force`), or as the paper's eq. 7
rotated into W with the measured orientation. Per frame (30 Hz): predict, undistort,
search each predicted feature in its 3-sigma ellipse, fuse the matches in one update, convert
well-determined inverse-depth features to XYZ, delete unreliable ones and initialise new ones
in empty regions while fewer than ``target_features`` are in view. Without the IMU the filter
predicts from frame to frame (the paper's "camera only"); without the camera it integrates
the IMU alone ("inertial only", Fig. 8).

A frame in which no feature matched (camera covered, a blank wall, a fast jump) is fused with
nothing: the filter coasts on the IMU with a growing covariance, and such frames count
against no feature (the failure is the frame's, not the feature's).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from humimic.estimation.ekf import motion_model as mm
from humimic.estimation.ekf.frontend import MEASURED, Frontend, FrontendParams
from humimic.estimation.ekf.slam import SlamFilter, SlamParams
from humimic.maths.blas import one_blas_thread
from humimic.sensors.camera_model import Intrinsics


@dataclass(frozen=True)
class EstimatorSettings:
    use_camera: bool = True
    use_orientation: bool = True
    use_accel: bool = True
    use_gyro: bool = True
    accel_in_sensor_frame: bool = True
    """Compare the accelerometer's reading in its own frame (:func:`mm.h_specific_force`)
    instead of rotated into W by the measured orientation (the paper's eq. 7)."""
    target_features: int = 20
    """Add new features while fewer than this many are predicted in view."""
    max_map: int = 60
    """Never hold more features than this (the oldest unseen go first)."""
    max_measured: int | None = None
    """Search at most this many features per frame (most uncertain first); None: all."""
    max_new_per_frame: int = 6
    prune_min_tries: int = 10
    prune_min_ratio: float = 0.5
    prune_misses_in_row: int = 10
    slam: SlamParams = SlamParams()
    frontend: FrontendParams = FrontendParams()


@dataclass
class FrameReport:
    """What one frame did (for the recording, the metrics and the Fig. 7 overlay)."""

    t: float
    fids: np.ndarray
    """(k,) predicted-visible feature ids."""
    uv: np.ndarray
    """(k, 2) predicted undistorted pixels."""
    S: np.ndarray
    """(k, 2, 2) innovation covariances (px^2)."""
    status: np.ndarray
    """(k,) MEASURED / FAILED / NOT_SELECTED (:mod:`.frontend`)."""
    z: np.ndarray
    """(m, 2) measured pixels of the MEASURED ones, in their order."""
    added: int = 0
    deleted: int = 0
    converted: int = 0
    cycle_s: float = 0.0
    cycle_cpu_s: float = 0.0
    """The same in this thread's CPU time (less disturbed by other processes on the machine)."""
    """Wall time of this frame's estimation, the IMU updates since the last frame included."""
    map_size: int = 0
    new_uv: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def n_measured(self) -> int:
        return int(np.sum(self.status == MEASURED))


class WearableSlam:
    """EKF SLAM with the head IMU; pixels in the undistorted image, poses of I in W."""

    def __init__(self, t0: float, x0: np.ndarray, P0: np.ndarray, intr: Intrinsics,
                 R_cv_I: np.ndarray, g_W: np.ndarray, known_W: np.ndarray | None = None,
                 settings: EstimatorSettings = EstimatorSettings()):
        self.settings = settings
        self.g_W = np.asarray(g_W, float)
        self.filter = SlamFilter(t0, x0, P0, intr, R_cv_I, settings.slam)
        self.frontend = Frontend(intr, settings.frontend)
        self.known = (self.filter.add_known(known_W) if known_W is not None and len(known_W)
                      else [])
        self._pending_s = 0.0  # IMU work since the last frame (part of the next cycle)
        self._pending_cpu = 0.0

    @property
    def x(self) -> np.ndarray:
        return self.filter.interface

    # ---- IMU -------------------------------------------------------------------------------
    def on_imu(self, t: float, accel_I: np.ndarray, R_W_I: np.ndarray | None,
               gyro_I: np.ndarray | None = None) -> None:
        """One head-IMU sample: specific force in I, the sensor's orientation in W and its
        angular rate in I (each fused if given and enabled). BLAS on one thread (as in
        :meth:`on_frame`): the same bits whatever the thread count."""
        with one_blas_thread():
            self._on_imu(t, accel_I, R_W_I, gyro_I)

    def _on_imu(self, t: float, accel_I: np.ndarray, R_W_I: np.ndarray | None,
                gyro_I: np.ndarray | None) -> None:
        t0, c0 = time.perf_counter(), time.thread_time()
        s = self.settings
        self.filter.predict(t)
        q_meas = a_W = w = f_I = None
        if R_W_I is not None:
            q_meas = mm.quat_from_matrix(R_W_I) if s.use_orientation else None
            if s.use_accel and not s.accel_in_sensor_frame:
                a_W = mm.world_acceleration(accel_I, R_W_I, self.g_W)
        if s.use_accel and s.accel_in_sensor_frame:
            f_I = np.asarray(accel_I, float)
        if gyro_I is not None and s.use_gyro:
            w = np.asarray(gyro_I, float)
        self.filter.update_inertial(q_meas, a_W, w, f_I, self.g_W)
        self._pending_s += time.perf_counter() - t0
        self._pending_cpu += time.thread_time() - c0

    # ---- camera ----------------------------------------------------------------------------
    def on_frame(self, t: float, image: np.ndarray, mask: np.ndarray | None = None,
                 known_uv: np.ndarray | None = None) -> FrameReport:
        """One head-camera frame (distorted RGB as captured; ``mask``: the wearer's arm in the
        *undistorted* image (bool, full size), never matched nor detected in; ``known_uv``:
        where the known features are in this frame, if known -- see
        :meth:`_cut_known_patches`). BLAS on one thread: with OpenBLAS's default two, the
        Sugiyama arm scenario's covariance differed in the last bits from one thread's from
        the 35th frame (2 s: 8 metrics at ~1e-15 relative)."""
        with one_blas_thread():
            return self._on_frame(t, image, mask, known_uv)

    def _on_frame(self, t: float, image: np.ndarray, mask: np.ndarray | None,
                  known_uv: np.ndarray | None) -> FrameReport:
        t0, c0 = time.perf_counter(), time.thread_time()
        s, f, fe = self.settings, self.filter, self.frontend
        f.predict(t)
        if not s.use_camera:
            return self._report(t, t0, c0)
        grey = fe.undistort(image)
        umask = mask
        pred = f.predict_features()
        self._cut_known_patches(grey, pred, known_uv)
        select = self._select(pred)
        m = fe.match(grey, pred.fids, pred.uv, pred.S, umask, select)
        if len(m.index):
            f.update_features(pred, m.index, m.uv)
            deleted = f.prune(s.prune_min_tries, s.prune_min_ratio, s.prune_misses_in_row)
        else:  # a frame with nothing usable blames no feature
            deleted = []
        fe.drop(deleted)
        converted = f.convert_linear()
        report = FrameReport(t, pred.fids, pred.uv, pred.S, m.status, m.uv,
                             deleted=len(deleted), converted=len(converted))
        self._add_features(grey, umask, report)
        return self._report(t, t0, c0, report)

    def _report(self, t: float, t0: float, c0: float, report: FrameReport | None = None
                ) -> FrameReport:
        if report is None:
            e = np.zeros((0,))
            report = FrameReport(t, e.astype(int), np.zeros((0, 2)), np.zeros((0, 2, 2)),
                                 e.astype(int), np.zeros((0, 2)))
        report.cycle_s = self._pending_s + time.perf_counter() - t0
        report.cycle_cpu_s = self._pending_cpu + time.thread_time() - c0
        report.map_size = self.filter.n_features
        self._pending_s = self._pending_cpu = 0.0
        return report

    def _select(self, pred) -> np.ndarray | None:
        cap = self.settings.max_measured
        if cap is None or len(pred.fids) <= cap:
            return None
        order = np.argsort(-np.trace(pred.S, axis1=1, axis2=2))  # most uncertain first
        sel = np.zeros(len(pred.fids), bool)
        sel[order[:cap]] = True
        return sel

    def _cut_known_patches(self, grey: np.ndarray, pred, known_uv: np.ndarray | None) -> None:
        """Cut the patches of the known features: at ``known_uv`` (undistorted pixels, one row
        per known feature, NaN where not in view) when given -- the start calibration: where
        the corners are seen from the marked start position -- and otherwise the first time the
        filter predicts one sharply (innovation covariance trace under 6 px^2)."""
        fe = self.frontend
        if known_uv is not None:
            for fid, uv in zip(self.known, np.asarray(known_uv, float), strict=True):
                if fid not in fe.patches and np.all(np.isfinite(uv)):
                    fe.add([fid], grey, uv[None])
        for fid, uv, S in zip(pred.fids, pred.uv, pred.S, strict=True):
            if int(fid) in self.known and int(fid) not in fe.patches and np.trace(S) < 6.0:
                fe.add([fid], grey, uv[None])

    def _add_features(self, grey: np.ndarray, umask, report: FrameReport) -> None:
        s, f, fe = self.settings, self.filter, self.frontend
        in_view = len(report.fids) - report.deleted
        want = min(s.target_features - in_view, s.max_new_per_frame)
        if want <= 0:
            return
        room = s.max_map - f.n_features
        if room < want:
            self._forget_unseen(want - room, report.fids)
        uv = fe.detect(grey, want, report.uv, umask)
        if len(uv) == 0:
            return
        fids = f.add_features(uv)
        bad = fe.add(fids, grey, uv)
        f.delete(bad)
        report.added = len(fids) - len(bad)
        report.new_uv = uv

    def _forget_unseen(self, n: int, in_view: np.ndarray) -> None:
        """Drop ``n`` features not in view, least matched first (keeps the map bounded)."""
        seen = set(int(i) for i in in_view)
        cand = [ft for ft in self.filter.features if not ft.known and ft.fid not in seen]
        cand.sort(key=lambda ft: (ft.hits, ft.fid))
        drop = [ft.fid for ft in cand[:n]]
        self.filter.delete(drop)
        self.frontend.drop(drop)
