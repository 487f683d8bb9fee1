"""What the SLAM stage keeps per frame, and the ``slam.*`` scores computed from it.

Scores compare the estimated interface pose (the head camera's frame I in the paper's W) with
the ground truth at each frame's photon time. The screen's known corners fix W, so the plain
error is the headline (``ate_rmse_m``); the aligned variants (SE(3), Sim(3), Umeyama) say how
much of it is a rigid offset or a scale error of the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from humimic.maths.align import DegenerateAlignment
from humimic.maths.stats import chi2_band, finite_or_none, nees, rmse
from humimic.maths.trajectory import ape, rpe
from humimic.motion import quat
from humimic.spill import SpillRows

#: Relative pose error over this time (s): :func:`rpe_delta_frames` frames at the head camera's
#: rate (30 at the paper's 30 Hz; before, 30 frames at any rate: 2 s at 15 Hz).
RPE_WINDOW_S = 1.0


def rpe_delta_frames(t: np.ndarray) -> int:
    """Frames spanning :data:`RPE_WINDOW_S` at the median frame interval of ``t`` (at least 1)."""
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return max(1, round(RPE_WINDOW_S / dt)) if dt > 0 else 1


@dataclass
class SlamRecord:
    """Rows appended by the stage, one per head-camera frame."""

    rows: SpillRows = field(default_factory=SpillRows)

    def add(self, t: float, x: np.ndarray, P: np.ndarray, report, added_on_arm: int = 0
            ) -> None:
        status = report.status
        self.rows.append((t, x[0:3].copy(), x[3:7].copy(), P[0:7, 0:7].copy(),
                          len(report.fids), int(np.sum(status == 0)), int(np.sum(status == 1)),
                          report.added, report.deleted, report.converted, report.map_size,
                          report.cycle_s, report.cycle_cpu_s, added_on_arm))

    def arrays(self) -> dict[str, np.ndarray]:
        names = ("t", "p", "q", "P", "predicted", "measured", "failed", "added", "deleted",
                 "converted", "map_size", "cycle_s", "cycle_cpu_s", "added_on_arm")
        if not self.rows:
            return {n: np.zeros(0) for n in names}
        return dict(zip(names, self.rows.columns(), strict=True))


def heading(R_W_I: np.ndarray) -> np.ndarray:
    """Heading (rad) of the optical axis (I's z) about W's vertical y: ``atan2(z_x, z_z)``."""
    z = R_W_I[..., :, 2]
    return np.arctan2(z[..., 0], z[..., 2])


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def pose_errors(p: np.ndarray, q: np.ndarray, p_true: np.ndarray, R_true: np.ndarray
                ) -> dict[str, np.ndarray]:
    """Per-frame position error (m, W), heading error and whole-rotation error (rad)."""
    R = quat.to_matrix(q)
    dR = np.einsum("nji,njk->nik", R_true, R)
    return {"position": p - p_true, "heading": wrap(heading(R) - heading(R_true)),
            "rotation": quat.rotation_angle(dR)}


def trajectory_scores(t: np.ndarray, p: np.ndarray, q: np.ndarray, p_true: np.ndarray,
                      R_true: np.ndarray) -> dict:
    """ATE after SE(3) and Sim(3) alignment (Umeyama) and the RPE over :data:`RPE_WINDOW_S`
    (:mod:`humimic.maths.trajectory`, evo's conventions). The alignments are None for an
    estimate with non-finite rows (a diverged filter); the Sim(3) scores are None when the true
    path's RMS spread about its mean is not above the SE(3) ATE: a wearer standing (nearly)
    still, whose scale would be fitted to the estimate's noise (a 1 um sway under 5 mm of
    jitter gave a scale of 7e-6 and a "perfect" ATE of 0.7 um)."""
    T_est = np.zeros((len(t), 4, 4))
    T_est[:, :3, :3], T_est[:, :3, 3], T_est[:, 3, 3] = quat.to_matrix(q), p, 1.0
    T_ref = T_est.copy()
    T_ref[:, :3, :3], T_ref[:, :3, 3] = R_true, p_true
    out: dict = {}
    if len(t) >= 3:
        out.update(ate_se3_rmse_m=None, ate_sim3_rmse_m=None, sim3_scale=None)
        if not np.all(np.isfinite(T_est)):   # diverged: no alignment (its SVD fails)
            return _with_rpe(out, t, T_ref, T_est)
        out["ate_se3_rmse_m"] = ate_se3 = finite_or_none(ape(t, T_ref, t, T_est, "se3").rmse_m)
        spread = rmse(p_true - p_true.mean(axis=0))
        if ate_se3 is not None and spread > ate_se3:
            try:
                sim3 = ape(t, T_ref, t, T_est, "sim3")
                out["ate_sim3_rmse_m"] = finite_or_none(sim3.rmse_m)
                out["sim3_scale"] = finite_or_none(sim3.scale)
            except DegenerateAlignment:  # the estimate did not move: no scale is defined
                pass
    return _with_rpe(out, t, T_ref, T_est)


def _with_rpe(out: dict, t: np.ndarray, T_ref: np.ndarray, T_est: np.ndarray) -> dict:
    delta = rpe_delta_frames(t)
    if len(t) > delta:
        out["rpe_rmse_m"] = finite_or_none(rpe(t, T_ref, t, T_est, delta).rmse_m)
        out["rpe_delta_frames"] = delta
    return out


def slam_metrics(arr: dict[str, np.ndarray], p_true: np.ndarray, R_true: np.ndarray,
                 mode: str) -> dict:
    """``slam.*`` scores (see :mod:`humimic.estimation.ekf.slam_stage` for each key)."""
    n = len(arr["t"])
    out: dict = {"mode": mode, "frames": n}
    if n == 0:
        return out
    e = pose_errors(arr["p"], arr["q"], p_true, R_true)
    ep = e["position"]
    out.update({
        "ate_rmse_m": finite_or_none(rmse(ep)),
        "horizontal_rmse_m": finite_or_none(rmse(ep[:, [0, 2]])),
        "vertical_rmse_m": finite_or_none(rmse(ep[:, 1])),
        "position_max_error_m": finite_or_none(np.max(np.linalg.norm(ep, axis=1))),
        "heading_rmse_deg": finite_or_none(math.degrees(rmse(e["heading"]))),
        "rotation_rmse_deg": finite_or_none(math.degrees(rmse(e["rotation"]))),
    })
    out.update(trajectory_scores(arr["t"], arr["p"], arr["q"], p_true, R_true))
    camera = mode != "inertial"
    measured = arr["measured"]
    out.update({
        "features_per_frame": float(np.mean(measured)) if camera else 0.0,
        "features_predicted_per_frame": float(np.mean(arr["predicted"])) if camera else 0.0,
        "frames_without_features": int(np.sum(measured == 0)) if camera else n,
        "frames_without_features_fraction": float(np.mean(measured == 0)) if camera else 1.0,
        "map_size_mean": float(np.mean(arr["map_size"])),
        "features_added": int(np.sum(arr["added"])),
        "features_deleted": int(np.sum(arr["deleted"])),
        "features_converted_xyz": int(np.sum(arr["converted"])),
        "features_added_on_arm": int(np.sum(arr["added_on_arm"])),
        "cycle_ms": float(1e3 * np.mean(arr["cycle_s"])),
        "cycle_ms_p95": float(1e3 * np.percentile(arr["cycle_s"], 95)),
        "cycle_cpu_ms": float(1e3 * np.mean(arr["cycle_cpu_s"])),
    })
    v = nees(ep, arr["P"][:, 0:3, 0:3])
    lo, hi = chi2_band(3, 1)
    ok = np.isfinite(v)
    out["position_nees_mean"] = finite_or_none(np.mean(v[ok]) if ok.any() else math.nan)
    out["position_nees_in_band_fraction"] = finite_or_none(
        np.mean((v[ok] >= lo) & (v[ok] <= hi)) if ok.any() else math.nan)
    out["position_std_final_m"] = finite_or_none(
        math.sqrt(max(float(np.trace(arr["P"][-1, 0:3, 0:3])), 0.0)))
    return out
