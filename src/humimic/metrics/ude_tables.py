"""The numbers of Ude & Atkeson's Tables 2 and 3 and Fig. 1, computed from a run's records.

Table 2 (a static object): the empirical covariances of the two image points of each stereo
correspondence (px^2) and of the triangulated 3-D points, against the 3-D covariance obtained by
propagating the 2-D ones through triangulation -- both the paper's way (left and right points
independent) and the way this matcher needs (:func:`~humimic.perception.blobs.stereo.
following_covariance`: the right match follows the template cut at the left blob centre).

Table 3 (a static hand): mean and standard deviation of raw and filtered positions and of the
filter's velocities and accelerations (true value 0), in mm. The paper works in the left eye's
frame (z along its optical axis, the depth), so 3-D results are also given in the left camera's
OpenCV frame (x right, y down, z forward) at the first frame; the base frame's depth axis is x.

Fig. 1: per-axis RMSE of the filter's p, v, a against the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.estimation.random_jerk import RandomJerkFilter
from humimic.metrics.tracking import FILTER_SETTLE_S
from humimic.perception.blobs.stereo import (
    StereoRig,
    epipolar_direction,
    following_covariance,
)
from humimic.sensors.camera_model import invert_transform

MM = 1e3

#: Ude & Atkeson's Table 2: 2-D covariances (px^2) and 3-D covariances (mm^2, eye frame).
PAPER_TABLE2 = {
    "cov_left_px2": [[0.65, -0.023], [-0.023, 0.67]],
    "cov_right_px2": [[0.66, -0.012], [-0.012, 0.67]],
    "empirical_mm2": [[44.0, -16.0, -240.0], [-16.0, 9.4, 93.0], [-240.0, 93.0, 1400.0]],
    "propagated_mm2": [[43.0, -15.0, -230.0], [-15.0, 8.5, 88.0], [-230.0, 88.0, 1400.0]],
}
#: Ude & Atkeson's Table 3 (mm, mm/s, mm/s^2; x, y, z of the eye frame).
PAPER_TABLE3 = {
    "raw_mean": [-88.9, 221.1, 1024.6], "filtered_mean": [-88.7, 219.9, 1019.2],
    "vel_mean": [-0.27, 0.78, 3.71], "acc_mean": [-2.34, 2.37, 12.88],
    "raw_std": [2.96, 7.92, 35.00], "filtered_std": [1.82, 3.93, 16.80],
    "vel_std": [25.02, 28.30, 91.78], "acc_std": [200.25, 164.59, 263.88],
}


@dataclass
class Table2:
    n: int
    cov_left_px2: np.ndarray
    cov_right_px2: np.ndarray
    cross_px2: np.ndarray
    """Covariance between the left point (rows) and the right match (columns)."""
    match_std_px: float
    """Standard deviation of the right match along the epipolar line, relative to the left."""
    empirical: np.ndarray
    propagated_following: np.ndarray
    propagated_independent: np.ndarray
    online_R: np.ndarray
    """Mean of the covariances R the stage published (configured pixel_std, match_std)."""
    frame: str
    """'base' or 'camera' (the left eye's OpenCV frame at the first used frame); m^2."""


def _used(pa, target: str, skip_s: float) -> tuple[int, np.ndarray]:
    i = pa.index(target)
    ok = pa.ok[:, i]
    if not ok.any():
        raise ValueError(f"{target!r} was never measured")
    t0 = pa.t[np.argmax(ok)]
    return i, np.flatnonzero(ok & (pa.t >= t0 + skip_s))


def _to_camera(pa, frames: np.ndarray):
    """Rotation base -> left camera (OpenCV axes) at the first used frame, and its origin."""
    T = invert_transform(pa.T_base_cam[frames[0], 0])
    return T[:3, :3], T[:3, 3]


def table2(pa, target: str, skip_s: float = FILTER_SETTLE_S, frame: str = "camera") -> Table2:
    """Table 2 from a static target's measurements (``skip_s`` after its first one)."""
    i, frames = _used(pa, target, skip_s)
    uv = pa.uv_match[frames, i].reshape(-1, 4)
    C4 = np.cov(uv.T)
    Cl, Cr = C4[:2, :2], C4[2:, 2:]
    cams = [(pa.camera(f, 0), pa.camera(f, 1)) for f in frames]
    t_dir = np.array([epipolar_direction(cl, cr, p)
                      for (cl, cr), p in zip(cams, pa.p_base[frames, i], strict=True)])
    match_std = float(np.std(np.einsum("ni,ni->n", uv[:, 2:] - uv[:, :2], t_dir)))
    R_f, R_i = [], []
    for (cl, cr), u, t in zip(cams, uv, t_dir, strict=True):
        rig = StereoRig(cl, cr)
        R_f.append(rig.triangulate(u[:2], u[2:], cov_joint=following_covariance(
            Cl, match_std, t[None])[0])[1])
        R_i.append(rig.triangulate(u[:2], u[2:], Cl, Cr)[1])
    mats = [np.cov(pa.p_base[frames, i].T), np.mean(R_f, 0), np.mean(R_i, 0),
            np.mean(pa.R_base[frames, i], 0)]
    if frame == "camera":
        Rc, _ = _to_camera(pa, frames)
        mats = [Rc @ m @ Rc.T for m in mats]
    return Table2(len(frames), Cl, Cr, C4[:2, 2:], match_std, *mats, frame)


def refilter(t: np.ndarray, ok: np.ndarray, z: np.ndarray, R: np.ndarray, b: float,
             max_gap: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Run a :class:`RandomJerkFilter` of amplitude ``b`` over recorded measurements.

    Returns the states ``(F, 9)`` (NaN before the first measurement or after a reset) and the
    seconds since (re)initialisation ``(F,)``.
    """
    kf = RandomJerkFilter(b, max_gap=max_gap)
    x = np.full((len(t), 9), np.nan)
    since = np.full(len(t), np.inf)
    for k in range(len(t)):
        kf.step(t[k], z[k] if ok[k] else None, R[k] if ok[k] else None)
        if kf.initialised:
            x[k], since[k] = kf.x, kf.since_init
    return x, since


def table3(pa, target: str, x_filtered: np.ndarray, since: np.ndarray,
           skip_s: float = FILTER_SETTLE_S,
           frame: str = "camera") -> dict[str, np.ndarray]:
    """Table 3's rows (mm, mm/s, mm/s^2 per axis) from raw measurements and filter states
    ``(F, 9)`` aligned with the perception frames; frames ``skip_s`` after the filter started."""
    i, frames = _used(pa, target, skip_s)
    frames = frames[(since[frames] >= skip_s) & np.isfinite(since[frames])
                    & np.isfinite(x_filtered[frames, 0])]
    p_raw, x = pa.p_base[frames, i], x_filtered[frames]
    Rc, tc = (np.eye(3), np.zeros(3)) if frame == "base" else _to_camera(pa, frames)
    raw, pos = p_raw @ Rc.T + tc, x[:, 0:3] @ Rc.T + tc
    vel, acc = x[:, 3:6] @ Rc.T, x[:, 6:9] @ Rc.T
    out = {"n": np.array(len(frames))}
    for key, v in (("raw", raw), ("filtered", pos), ("vel", vel), ("acc", acc)):
        out[f"{key}_mean"] = MM * v.mean(axis=0)
        out[f"{key}_std"] = MM * v.std(axis=0)
    return out


def filter_white_noise(raw_std_mm, b: float, rate: float = 60.0, n: int = 3000,
                       seed: int = 0, skip_s: float = 1.0) -> dict[str, np.ndarray]:
    """Table 3's filter rows for a still target measured with white noise of standard
    deviation ``raw_std_mm`` (mm per axis; R the same): the filter (amplitude ``b``, m s^-2.5)
    run at ``rate`` Hz for ``n`` frames; spreads (mm, mm/s, mm/s^2) after ``skip_s``. This is
    how the paper's Table 3 pins down its effective b: its filtered/raw ratio and its v and a
    spreads follow from b and the raw spread alone."""
    sigma = 1e-3 * np.asarray(raw_std_mm, float)
    z = np.random.default_rng(seed).normal(size=(n, 3)) * sigma
    kf, R = RandomJerkFilter(b), np.diag(sigma**2)
    x = np.array([kf.step(k / rate, z[k], R) for k in range(n)])[int(skip_s * rate):]
    return {"filtered_std": MM * x[:, 0:3].std(axis=0), "vel_std": MM * x[:, 3:6].std(axis=0),
            "acc_std": MM * x[:, 6:9].std(axis=0)}


def fig1_rmse(x: np.ndarray, valid: np.ndarray, p: np.ndarray, v: np.ndarray, a: np.ndarray
              ) -> dict[str, np.ndarray]:
    """Per-axis RMSE of estimated p (mm), v (mm/s), a (mm/s^2) over ``valid`` frames."""
    out = {}
    for key, sl, truth in (("p", slice(0, 3), p), ("v", slice(3, 6), v),
                           ("a", slice(6, 9), a)):
        e = x[valid, sl] - truth[valid]
        out[key] = MM * np.sqrt(np.mean(e * e, axis=0))
    return out
