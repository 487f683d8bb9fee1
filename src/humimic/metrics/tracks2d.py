"""Image-space scores of 2-D trackers (``trackers.<name>.*``) against projected ground truth.

The truth is the target's site projected into the tracker's camera at each frame's photon time
(:func:`project_truth`: centre, size in pixels from the target's physical size and depth,
whether it is in view). A frame is

* *on target* when the tracker reports ``tracking`` and its centre is within the gate
  ``max(gate_px, gate_size * true size)`` of the projected truth;
* *lost* when the target is visible but the tracker is not on it (reporting ``lost``/``init``,
  or ``tracking`` something else: a track far off the target is not counted as tracking);
* *on the wrong person* when the target is visible and the tracker reports ``tracking``, is
  off its target, and is within the gate of another person's projected head (people given by
  ``others``). While the target is hidden, such frames count as
  ``on_other_while_hidden_frames`` instead.

Scores (:func:`scores`): ``frames``, ``visible_frames``, ``center_rmse_px`` /
``center_median_px`` (over visible frames the tracker reports ``tracking``, wherever it is),
``scale_rmse_px`` (true size vs estimated), ``on_target_rmse_px``, ``lost_fraction`` (of the
visible frames), ``false_track_fraction`` (frames the target is out of view or hidden but the
tracker claims to track it, of such frames), ``identity_switches`` (episodes on another person
while the target is in view), ``wrong_person_frames``, ``on_other_while_hidden_frames``,
``acquire_s`` (first visible to first on target) and ``reacquire_s`` (per event: the target
becoming visible again after being out of view or hidden, to on target; null when never
re-acquired), ``reacquire_max_s``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.maths.stats import finite_or_none, rmse
from humimic.sensors.camera_model import CameraModel, invert_transform

GATE_PX = 10.0
"""Smallest on-target gate (px)."""
GATE_SIZE = 1.0
"""On-target gate as a multiple of the target's true size in pixels."""


@dataclass(frozen=True)
class ImageTruth:
    """A target's projection in one camera over F frames."""

    uv: np.ndarray
    """(F, 2) px (NaN behind the camera)."""
    size_px: np.ndarray
    """(F,) apparent size of the physical size (px)."""
    visible: np.ndarray
    """(F,) bool: in front of the camera and the centre inside the image (a stage may use
    the world's visibility ground truth instead: in view and unoccluded)."""
    depth: np.ndarray | None = None
    """(F,) distance along the optical axis (m)."""


def project_truth(cameras: list[CameraModel], p_base: np.ndarray, size_m: float,
                  margin_px: float = 0.0) -> ImageTruth:
    """Project true positions ``p_base (F, 3)`` (robot base frame) through each frame's camera;
    the apparent size is ``f_x size_m / depth``. ``margin_px``: a centre closer than this to
    the border counts as out of view."""
    F = len(cameras)
    uv = np.full((F, 2), np.nan)
    size, depth = np.full(F, np.nan), np.full(F, np.nan)
    vis = np.zeros(F, bool)
    for k, cam in enumerate(cameras):
        T = invert_transform(cam.T_base_cam)
        p_cam = T[:3, :3] @ np.asarray(p_base[k], float) + T[:3, 3]
        depth[k] = p_cam[2]
        if p_cam[2] <= 1e-6:
            continue
        intr = cam.intrinsics
        uv[k] = intr.project(p_cam)
        size[k] = intr.fx * size_m / p_cam[2]
        vis[k] = (margin_px <= uv[k, 0] < intr.width - margin_px
                  and margin_px <= uv[k, 1] < intr.height - margin_px)
    return ImageTruth(uv, size, vis, depth)


def gate(size_px: np.ndarray, gate_px: float = GATE_PX, gate_size: float = GATE_SIZE
         ) -> np.ndarray:
    return np.maximum(gate_px, gate_size * np.nan_to_num(np.asarray(size_px, float)))


def on_target(est_uv: np.ndarray, tracking: np.ndarray, truth: ImageTruth,
              gate_px: float = GATE_PX, gate_size: float = GATE_SIZE) -> np.ndarray:
    """(F,) bool: tracking, target visible, centre within the gate."""
    err = np.linalg.norm(np.asarray(est_uv, float) - truth.uv, axis=1)
    with np.errstate(invalid="ignore"):
        near = err <= gate(truth.size_px, gate_px, gate_size)
    return np.asarray(tracking, bool) & truth.visible & near


def rising_edges(flag: np.ndarray) -> np.ndarray:
    """Indices where a boolean series turns True (index 0 counts when it starts True)."""
    f = np.asarray(flag, bool)
    return np.flatnonzero(f & ~np.concatenate([[False], f[:-1]]))


def reacquire_times(t: np.ndarray, visible: np.ndarray, on: np.ndarray
                    ) -> tuple[float, list[float]]:
    """``(acquire_s, [reacquire_s per event])``: from the first visible frame to the first on
    target, and from each later return into view to the first on-target frame of that visible
    spell (NaN if the spell ends first)."""
    t = np.asarray(t, float)
    vis, on = np.asarray(visible, bool), np.asarray(on, bool)
    starts = rising_edges(vis)
    out = []
    for s in starts:
        stop = np.flatnonzero(~vis[s:])
        end = s + stop[0] if len(stop) else len(vis)
        hit = np.flatnonzero(on[s:end])
        out.append(float(t[s + hit[0]] - t[s]) if len(hit) else np.nan)
    if not len(out):
        return np.nan, []
    return out[0], out[1:]


def wrong_person(est_uv: np.ndarray, tracking: np.ndarray, on: np.ndarray,
                 others: list[ImageTruth], gate_px: float = GATE_PX,
                 gate_size: float = GATE_SIZE) -> np.ndarray:
    """(F,) bool: tracking, not on target, within the gate of another person in view."""
    out = np.zeros(len(on), bool)
    for o in others:
        err = np.linalg.norm(np.asarray(est_uv, float) - o.uv, axis=1)
        with np.errstate(invalid="ignore"):
            out |= o.visible & (err <= gate(o.size_px, gate_px, gate_size))
    return out & np.asarray(tracking, bool) & ~np.asarray(on, bool)


def scores(t: np.ndarray, est_uv: np.ndarray, est_scale: np.ndarray, tracking: np.ndarray,
           truth: ImageTruth, others: list[ImageTruth] | None = None,
           gate_px: float = GATE_PX, gate_size: float = GATE_SIZE) -> dict:
    """The image-space scores of one track (see the module docstring); JSON-ready."""
    t, est_uv = np.asarray(t, float), np.asarray(est_uv, float).reshape(-1, 2)
    tracking = np.asarray(tracking, bool)
    vis = truth.visible
    on = on_target(est_uv, tracking, truth, gate_px, gate_size)
    near_other = wrong_person(est_uv, tracking, on, others or [], gate_px, gate_size)
    wrong = near_other & truth.visible
    err = est_uv - truth.uv
    judged = vis & tracking
    acq, reacq = reacquire_times(t, vis, on)
    n_vis, n_hidden = int(vis.sum()), int((~vis).sum())
    norms = np.linalg.norm(err[judged], axis=1)
    return {
        "frames": len(t),
        "visible_frames": n_vis,
        "center_rmse_px": finite_or_none(rmse(err[judged])),
        "center_median_px": finite_or_none(np.median(norms)) if len(norms) else None,
        "on_target_rmse_px": finite_or_none(rmse(err[on])),
        "scale_rmse_px": finite_or_none(rmse((np.asarray(est_scale, float)
                                               - truth.size_px)[judged])),
        "lost_fraction": finite_or_none(1.0 - on[vis].mean()) if n_vis else None,
        "false_track_fraction": (finite_or_none(tracking[~vis].mean()) if n_hidden
                                 else None),
        "identity_switches": len(rising_edges(wrong)),
        "wrong_person_frames": int(wrong.sum()),
        "on_other_while_hidden_frames": int((near_other & ~truth.visible).sum()),
        "acquire_s": finite_or_none(acq),
        "reacquire_s": [finite_or_none(r) for r in reacq],
        "reacquire_max_s": (finite_or_none(np.max(reacq)) if reacq and np.all(np.isfinite(reacq))
                            else None),
    }
