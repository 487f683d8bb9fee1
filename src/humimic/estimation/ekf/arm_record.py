"""What the arm EKF did, frame by frame, and its scores against the ground truth.

Scores (``metrics.json`` ``arm``): the marker centre's position error in the head frame I
(``position_rmse_m``) and its depth error (``depth_rmse_m``, along I's optical axis z), over
every frame since the filter started, and over the frames whose marker was taken; the remote's
orientation error, split into its tilt (seen by the accelerometer's pitch and roll) and its
yaw about the down direction (seen by nothing: it is the start pose's, "directed to the front",
plus the gyro's drift; ``orientation_yaw_start_deg`` is the start's); the position NEES, its
mean and the fraction of frames inside the 95 % chi-square band; how often the marker was
seen; the estimator's cycle time.
The truth is the marker site (``wiimote_marker``) in the true head-camera frame (``headcam``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from humimic.estimation.ekf.arm_model import UP_W
from humimic.maths.stats import finite_or_none, fraction_in_band, nees, rmse
from humimic.motion import quat
from humimic.world.frames import R_CV_I


@dataclass
class ArmRecord:
    """One row per head-camera frame."""

    t: list = field(default_factory=list)
    x: list = field(default_factory=list)
    """(19,) state after the frame (NaN before the filter starts)."""
    P_p: list = field(default_factory=list)
    """(3, 3) position covariance."""
    measured: list = field(default_factory=list)
    """The marker was taken (started or updated)."""
    candidates: list = field(default_factory=list)
    """Marker-coloured regions passing the shape tests."""
    uv: list = field(default_factory=list)
    """Chosen region's undistorted centroid (NaN if none)."""
    p_head_W: list = field(default_factory=list)
    R_head_W: list = field(default_factory=list)
    """The head pose the filter used (W)."""
    frame_s: list = field(default_factory=list)
    """Wall time (s) spent on this frame and the Wii samples before it."""

    def add(self, t, x, P, measured, n_cands, uv, head, frame_s) -> None:
        self.t.append(t)
        self.x.append(np.full(19, np.nan) if x is None else x.copy())
        self.P_p.append(np.full((3, 3), np.nan) if P is None else P[0:3, 0:3].copy())
        self.measured.append(bool(measured))
        self.candidates.append(int(n_cands))
        self.uv.append(np.full(2, np.nan) if uv is None else np.asarray(uv, float))
        self.p_head_W.append(np.asarray(head.p_W, float))
        self.R_head_W.append(np.asarray(head.R_W_I, float))
        self.frame_s.append(frame_s)

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v) for k, v in self.__dict__.items()}


def truth_in_head(gt, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """True marker centre in I (N, 3) and ``R_I_A`` (N, 3, 3) at times ``t``."""
    k = gt.index_of(np.asarray(t, float))
    T = gt.pose("headcam", "W")[k]
    p = gt.position("wiimote_marker", "W")[k]
    p_I = np.einsum("nji,nj->ni", T[:, :3, :3], p - T[:, :3, 3])
    R_IA = np.einsum("nji,njk->nik", T[:, :3, :3], gt.rotation("wiimote", "W")[k])
    return p_I, R_IA


def in_view(p_I: np.ndarray, K) -> np.ndarray:
    """Whether each marker centre (N, 3) in I projects inside the (pinhole) image."""
    c = p_I @ R_CV_I.T
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K.fx * c[:, 0] / c[:, 2] + K.cx
        v = K.fy * c[:, 1] / c[:, 2] + K.cy
    return (c[:, 2] > 0) & (u >= 0) & (u <= K.width - 1) & (v >= 0) & (v <= K.height - 1)


def tilt_and_yaw(R_est: np.ndarray, R_true: np.ndarray, down: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The orientation error ``R_est R_true^T`` (N, 3, 3, in I) split about the true down
    direction ``down`` (N, 3, in I): its tilt (the angle it turns ``down`` by, what the
    accelerometer's pitch and roll see) and its yaw (the twist about ``down``, which no arm
    measurement sees), both in degrees."""
    R_err = R_est @ np.swapaxes(R_true, -1, -2)
    cos = np.einsum("ni,nij,nj->n", down, R_err, down)
    tilt = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return tilt, np.degrees(quat.twist_angle(R_err, down))


def arm_errors(rec: ArmRecord, gt) -> dict[str, np.ndarray]:
    """Per-frame errors: position (N, 3) in I, orientation angle, its tilt and yaw (deg),
    NEES."""
    a = rec.arrays()
    if len(a["t"]) == 0:
        return {}
    p_true, R_true = truth_in_head(gt, a["t"])
    err = a["x"][:, 0:3] - p_true
    R_est = np.full_like(R_true, np.nan)
    ok = np.all(np.isfinite(a["x"][:, 3:7]), axis=1)
    R_est[ok] = quat.to_matrix(a["x"][ok, 3:7])
    ang = np.degrees(quat.rotation_angle(R_est @ np.swapaxes(R_true, -1, -2)))
    T = gt.pose("headcam", "W")[gt.index_of(a["t"])]
    down_I = -np.einsum("nji,j->ni", T[:, :3, :3], UP_W)
    tilt, yaw = np.full(len(ang), np.nan), np.full(len(ang), np.nan)
    tilt[ok], yaw[ok] = tilt_and_yaw(R_est[ok], R_true[ok], down_I[ok])
    return {"t": a["t"], "p_true": p_true, "err": err, "angle_deg": ang, "tilt_deg": tilt,
            "yaw_deg": yaw, "nees": nees(err, a["P_p"]), "measured": a["measured"]}


def arm_metrics(rec: ArmRecord, gt, K, ekf) -> dict:
    a = rec.arrays()
    e = arm_errors(rec, gt)
    if not e:
        return {"arm": {"frames": 0}}
    started = np.all(np.isfinite(a["x"][:, 0:3]), axis=1)
    meas = e["measured"] & started
    visible = in_view(e["p_true"], K)
    ms = 1e3 * a["frame_s"]
    out = {
        "frames": int(len(a["t"])),
        "position_rmse_m": finite_or_none(rmse(e["err"][started])),
        "depth_rmse_m": finite_or_none(rmse(e["err"][started, 2])),
        "depth_mean_error_m": finite_or_none(np.mean(e["err"][started, 2])
                                             if started.any() else np.nan),
        "position_rmse_measured_m": finite_or_none(rmse(e["err"][meas])),
        "depth_rmse_measured_m": finite_or_none(rmse(e["err"][meas, 2])),
        "orientation_rmse_deg": finite_or_none(rmse(e["angle_deg"][started])),
        "orientation_tilt_rmse_deg": finite_or_none(rmse(e["tilt_deg"][started])),
        "orientation_yaw_rmse_deg": finite_or_none(rmse(e["yaw_deg"][started])),
        "orientation_yaw_start_deg": finite_or_none(e["yaw_deg"][started][0]
                                                    if started.any() else np.nan),
        "nees_position_mean": finite_or_none(np.nanmean(e["nees"][started])
                                             if started.any() else np.nan),
        "nees_position_in_band_fraction": finite_or_none(fraction_in_band(e["nees"][started],
                                                                          3)),
        "marker_in_view_fraction": float(np.mean(visible)),
        "measured_fraction": float(np.mean(a["measured"])),
        "measured_in_view_fraction": finite_or_none(np.mean(a["measured"][visible])
                                                    if visible.any() else np.nan),
        "false_marker_frames": int(np.sum(a["measured"] & ~visible)),
        "restarts": int(ekf.restarts),
        "gated_out": int(ekf.rejected),
        "static_pitch_roll_updates": int(ekf.static_updates),
        "cycle_ms": finite_or_none(np.mean(ms) if len(ms) else np.nan),
        "cycle_p95_ms": finite_or_none(np.percentile(ms, 95) if len(ms) else np.nan),
    }
    return {"arm": out}


def arm_plot(rec: ArmRecord, gt, path) -> list:
    """Estimated and true marker position in I, and the errors, against time (PNG)."""
    import matplotlib.pyplot as plt

    e = arm_errors(rec, gt)
    if not e:
        return []
    t = e["t"]
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for i, name in enumerate(("x (left)", "y (up)", "z (depth)")):
        ax = axes[i]
        ax.plot(t, e["p_true"][:, i], "k-", lw=1.2, label="true")
        ax.plot(t, e["p_true"][:, i] + e["err"][:, i], "C3-", lw=1.0, label="arm EKF")
        m = e["measured"]
        ax.plot(t[m], (e["p_true"][:, i] + e["err"][:, i])[m], "C3.", ms=2)
        ax.set_ylabel(f"{name} [m]")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Wii remote marker in the head frame I")
    ax = axes[3]
    ax.plot(t, 100 * e["err"][:, 2], "C0-", lw=1.0, label="depth error")
    ax.plot(t, 100 * np.linalg.norm(e["err"], axis=1), "C1-", lw=1.0, label="position error")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("error [cm]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]
