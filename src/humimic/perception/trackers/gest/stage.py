"""The GEST pipeline stage: both eye images -> the hand's pose on ``poses``; scores against
the avatar's hand ellipsoid (``trackers.<name>.*``).

Scores are over the frames in which the true hand centre projects into the left image
(``in_view``): ``position_rmse_mm`` (3-D, frames the tracker reports ``tracking``),
``orientation_rmse_deg`` (geodesic angle, modulo the ellipsoid's symmetries: a half turn
about any of its axes looks the same), ``axes_rmse_mm``, ``within_30mm_fraction`` and
``tracked_in_view_fraction``; ``tracking_out_of_view_fraction`` counts frames it claims a hand
that is not in view. ``tracked_whole_in_view_fraction`` is over the frames in which the whole
hand (the true ellipsoid's outline) lies inside the left image: a hand cut by the border gives
no whole skin blob, and GEST reports it lost by design.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from humimic.bodymodel.avatar import truth_hand_state
from humimic.bodymodel.kinematics import ypr_matrix
from humimic.maths.stats import rmse
from humimic.messages import PoseEstimate
from humimic.perception.trackers.common import BAD, GOOD, PoseTrackerStage
from humimic.perception.trackers.gest.ellipsoid import FLIPS
from humimic.perception.trackers.gest.foveal import choose_pair
from humimic.perception.trackers.gest.likelihood import hand_outlines
from humimic.perception.trackers.gest.tracker import GestResult, GestTracker
from humimic.perception.trackers.gest.warmup import load_kernels
from humimic.sensors.camera_model import invert_transform
from humimic.viz.rerun_log import ESTIMATES, PIXEL_CENTRE_SHIFT, image_entity

PARTICLE = (90, 120, 255)

STATE_NAMES = ("x", "y", "z", "yaw", "pitch", "roll", "sigma_x", "sigma_y", "sigma_z")


def orientation_error_deg(ypr_est: np.ndarray, ypr_true: np.ndarray) -> np.ndarray:
    """Geodesic angle (deg) between estimated and true ellipsoid orientations ``(T, 3)``, the
    smallest over the ellipsoid's symmetries."""
    Re, Rt = ypr_matrix(*ypr_est.T), ypr_matrix(*ypr_true.T)
    rel = np.swapaxes(Rt, -1, -2)[:, None] @ Re[:, None] @ FLIPS[None]      # (T, 4, 3, 3)
    cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    return np.degrees(np.arccos(cos)).min(axis=1)


class GestStage(PoseTrackerStage):
    kind = "gest"

    def __init__(self, name: str, cfg, cameras: tuple[str, str], lut, world, rng, rlog=None,
                 foveal: tuple[str, str] | None = None):
        super().__init__(name, cfg.latency)
        self.cfg, self.cameras, self.world, self.rng, self.rlog = cfg, cameras, world, rng, rlog
        self.foveal = foveal
        self.tracker, self.skin_lut = GestTracker(cfg, lut), lut
        load_kernels(lut, cfg.bins)     # numba's kernels, before the first timed frame
        self.side = "R" if cfg.hand == "right" else "L"
        self.results: list[GestResult | None] = []
        self.left_cams: list = []
        """Per frame, the wide pair's left camera (the scores' view)."""
        self.used: list = []
        """Per frame, the left camera the tracker measured in (None without a frame)."""
        self.samples: list = []
        """Per frame, every ``n_particles // 20``-th particle (for the recording)."""

    def track(self, t: float, images: dict):
        wide = images.get(self.cameras[0]), images.get(self.cameras[1])
        if wide[0] is None or wide[1] is None:
            self.results.append(None)
            self.left_cams.append(None)
            self.used.append(None)
            self.samples.append(None)
            return None
        narrow = None if self.foveal is None else tuple(images.get(c) for c in self.foveal)
        left, right = choose_pair(wide, narrow, self.tracker.last, self.cfg.foveal_margin_px)
        if self.used and self.used[-1] is not None and self.used[-1].name != left.camera.name:
            self.tracker.offset = np.zeros(3)    # the silhouette offset is the other pair's
        narrowed = narrow is not None and left is narrow[0]
        res = self.tracker.step(left, right, self.rng,
                                silhouette_offset=self.cfg.foveal_offset or not narrowed,
                                foveal=narrowed)
        self.results.append(res)
        self.left_cams.append(wide[0].camera)
        self.used.append(left.camera)
        pf = self.tracker.pf
        self.samples.append(None if pf.particles is None else
                            pf.particles[::max(1, len(pf.particles) // 20)].copy())
        if res.mean is None:
            return PoseEstimate(self.tracker_name, self.kind, np.full(9, np.nan), STATE_NAMES,
                                None, {}, {}, res.status)
        return PoseEstimate(self.tracker_name, self.kind, res.mean, STATE_NAMES, res.cov,
                            {f"{self.side.lower()}_hand": res.mean[:3]}, {}, res.status)

    def log(self, rlog) -> None:
        """Over the left image: the MMSE ellipse (green tracking, red otherwise) and a sample
        of particles (blue); in 3-D, the estimated centre beside the avatar."""
        if rlog is None or not rlog.enabled:
            return
        T = self.world.gt.T_world_base
        for t, res, cam, sample in zip(self.times, self.results, self.used, self.samples,
                                       strict=True):
            if res is None or res.mean is None:
                continue
            base = f"{image_entity(cam.name)}/{self.tracker_name}"
            states = np.vstack([res.mean[None], sample])
            states[:, 6:] = np.maximum(states[:, 6:], 1e-3)
            outline = hand_outlines(states, cam.intrinsics, invert_transform(cam.T_base_cam))
            strips = [np.vstack([o, o[:1]]) + PIXEL_CENTRE_SHIFT for o in outline
                      if np.isfinite(o).all()]
            if not strips:
                continue
            rlog.log(t, f"{base}/particles", rr.LineStrips2D(strips[1:], colors=PARTICLE,
                                                              radii=0.5))
            rlog.log(t, f"{base}/estimate", rr.LineStrips2D(
                strips[:1], colors=GOOD if res.status == "tracking" else BAD, radii=1.0))
            rlog.log_points(t, f"{ESTIMATES}/{self.tracker_name}",
                            (T[:3, :3] @ res.mean[:3] + T[:3, 3])[None], colors=GOOD)

    def _judged(self):
        """Per frame: the true hand state (T, 9), the estimate (T, 9; NaN without one), whether
        the hand is in the left camera's view and whether the tracker reports tracking."""
        truth = truth_hand_state(self.world, self.world.gt.index_of(np.asarray(self.times)),
                                 self.side, "base")
        in_view = np.array([_in_view(c, p) for c, p in zip(self.left_cams, truth[:, :3],
                                                              strict=True)])
        tracking = np.array([r is not None and r.status == "tracking" for r in self.results])
        est = np.array([r.mean if r is not None and r.mean is not None else np.full(9, np.nan)
                        for r in self.results])
        return truth, est, in_view, tracking

    def error_series(self) -> dict:
        """The hand centre's 3-D error on frames it is in view and tracked (NaN elsewhere)."""
        if not self.times:
            return {}
        truth, est, in_view, tracking = self._judged()
        err = np.linalg.norm(est[:, :3] - truth[:, :3], axis=1)
        return {f"{self.side.lower()}_hand centre": (np.asarray(self.times),
                                                     np.where(in_view & tracking, err, np.nan))}

    def scores(self) -> dict:
        if not self.times:
            return {}
        truth, est, in_view, tracking = self._judged()
        use = in_view & tracking
        whole = np.array([_whole_in_view(c, x) for c, x in zip(self.left_cams, truth,
                                                                 strict=True)])
        out = {"in_view_frames": int(in_view.sum()),
               "tracked_in_view_fraction": _frac(use, in_view),
               "whole_in_view_frames": int(whole.sum()),
               "tracked_whole_in_view_fraction": _frac(whole & tracking, whole),
               "tracking_out_of_view_fraction": _frac(tracking & ~in_view, ~in_view)}
        if self.foveal is not None:
            narrow = np.array([c is not None and c.name == self.foveal[0] for c in self.used])
            out["foveal_tracked_fraction"] = _frac(narrow & use, use)
        if use.any():
            err = est[use, :3] - truth[use, :3]
            dist = np.linalg.norm(err, axis=1)
            out.update({
                "position_rmse_mm": 1e3 * rmse(err),
                "position_median_mm": 1e3 * float(np.median(dist)),
                "within_30mm_fraction": float(np.mean(dist <= 0.03)),
                "orientation_rmse_deg": float(np.sqrt(np.mean(
                    orientation_error_deg(est[use, 3:6], truth[use, 3:6]) ** 2))),
                "axes_rmse_mm": 1e3 * float(np.sqrt(np.mean((est[use, 6:] - truth[use, 6:]) ** 2))),
            })
        return out


def _frac(a: np.ndarray, of: np.ndarray) -> float | None:
    return float(a.sum() / of.sum()) if of.any() else None


def _in_view(camera, p_base: np.ndarray) -> bool:
    if camera is None:
        return False
    p_cam = invert_transform(camera.T_base_cam) @ np.r_[p_base, 1.0]
    if p_cam[2] <= 0.05:
        return False
    u, v = camera.intrinsics.project(p_cam[:3])
    return bool(0 <= u < camera.intrinsics.width and 0 <= v < camera.intrinsics.height)


def _whole_in_view(camera, state_base: np.ndarray) -> bool:
    """Whether the outline of the hand ellipsoid ``state_base (9,)`` lies inside the image."""
    if camera is None or not _in_view(camera, state_base[:3]):
        return False
    uv = hand_outlines(state_base[None], camera.intrinsics,
                       invert_transform(camera.T_base_cam))[0]
    w, h = camera.intrinsics.width, camera.intrinsics.height
    return bool(np.isfinite(uv).all() and (uv >= 0).all() and (uv[:, 0] <= w - 1).all()
                and (uv[:, 1] <= h - 1).all())
