"""GEST, Menezes et al.'s 3-D hand tracker (sec. 6.1, Table 5), for one stereo frame at a time.

State (eq. 16): the hand ellipsoid's centre (robot base frame, m), orientation (yaw pitch
roll, rad) and semi-axes (m); independent Gaussian random walks (Table 5's sigmas) with a small
chance of re-appearing anywhere in the workspace (:class:`.proposal.PoseReset`, so that
particles the importance function proposes after the hand left the view keep their weight).
ICONDENSATION (:func:`humimic.estimation.particles.icondensation_step`) mixes ``alpha``
particles from the stereo importance function (:mod:`.stereo`, :class:`.proposal.
CandidateProposal`), ``beta`` from the dynamics and the rest from the prior; the likelihood
is :mod:`.likelihood`'s. Initialisation is automatic: the filter starts from the importance
function at the first frame with a hand-sized stereo skin blob, and re-starts from it
whenever the estimate is lost (its contour off the edges by more than ``lost_px``, out of
the image, or ``lost_frames`` frames in a row without a stereo skin blob within ``lost_m``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from humimic.estimation.particles import (
    Gaussian,
    Mixture,
    ParticleFilter,
    RandomWalk,
    UniformBox,
)
from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.histograms import update_reference
from humimic.perception.cues.importance import skin_blobs
from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.gest.likelihood import (
    hand_log_likelihood,
    hand_view,
    patch_histogram,
    project_hands,
    shape_distance,
)
from humimic.perception.trackers.gest.proposal import CandidateProposal, PoseReset
from humimic.perception.trackers.gest.stereo import stereo_candidates
from humimic.sensors.camera_model import CameraImage

#: Floor (m) added to the triangulation's standard deviation in the importance function.
POSITION_FLOOR_M = 0.005


@dataclass(frozen=True)
class GestResult:
    mean: np.ndarray | None
    """(9,) MMSE state, None before the first detection."""
    cov: np.ndarray | None
    status: str
    """``searching`` (never locked on), ``tracking`` or ``lost``."""
    candidates: np.ndarray
    """(M, 3) triangulated skin blobs of this frame (base frame)."""
    shape_px: float
    """Mean contour distance of the MMSE estimate to the edges (left image, px)."""


def skin_mask(image: np.ndarray, lut: ColorLUT) -> np.ndarray:
    return (lut.posterior(image) > 0.5).astype(np.uint8)


def hand_prior(cfg: GestConfig) -> UniformBox:
    spread = np.asarray(cfg.axes) * cfg.axes_spread
    lo = np.r_[cfg.workspace_low, -math.pi, -math.pi / 2, -math.pi, np.asarray(cfg.axes) - spread]
    hi = np.r_[cfg.workspace_high, math.pi, math.pi / 2, math.pi,
               np.asarray(cfg.axes) + spread + 1e-6]
    return UniformBox(lo, hi)


def importance_function(p: np.ndarray, cov: np.ndarray, orientation: np.ndarray,
                        cfg: GestConfig, orientation_sigma_deg: float) -> Mixture | None:
    """A 9-D start density: one Gaussian per stereo candidate (eq. 17's covariance, floored),
    about ``orientation`` for the angles and the nominal semi-axes."""
    if len(p) == 0:
        return None
    o = math.radians(orientation_sigma_deg) ** 2
    a = (np.asarray(cfg.axes) * cfg.axes_spread / 2.0) ** 2
    parts = []
    for pj, cj in zip(p, cov, strict=True):
        C = np.zeros((9, 9))
        C[:3, :3] = cj + POSITION_FLOOR_M ** 2 * np.eye(3)
        C[3:6, 3:6] = o * np.eye(3)
        C[6:, 6:] = np.diag(a)
        parts.append(Gaussian(np.r_[pj, orientation, cfg.axes], C))
    return Mixture(tuple(parts))


class GestTracker:
    """One hand, one stereo pair; ``step`` per frame (module docstring)."""

    def __init__(self, cfg: GestConfig, lut: ColorLUT):
        self.cfg, self.lut = cfg, lut
        self.prior = hand_prior(cfg)
        self.walk = RandomWalk(cfg.sigma_walk)
        self.orientations = UniformBox(self.prior.low[3:6], self.prior.high[3:6])
        dynamics = PoseReset(self.walk, UniformBox(self.prior.low[:6], self.prior.high[:6]),
                             cfg.reset)
        self.pf = ParticleFilter("icondensation", dynamics, self.prior, cfg.n, cfg.alpha,
                                 cfg.beta)
        self.ref: np.ndarray | None = None
        self.orientation = np.zeros(3)
        self.locked = False
        self.unsupported = 0
        """Consecutive frames without a stereo candidate near the estimate."""

    def _ll(self, views, pairs):
        cfg = self.cfg
        w, h = views[0].dt.shape[1], views[0].dt.shape[0]
        outlier = cfg.stereo_outlier / float(w * h) ** 2

        def log_likelihood(x: np.ndarray) -> np.ndarray:
            x = x.copy()
            x[:, 6:] = np.maximum(x[:, 6:], 1e-3)
            return hand_log_likelihood(x, views, self.ref, cfg.n_points, cfg.sigma_s,
                                       cfg.sigma_c, cfg.sigma_k, cfg.views,
                                       pairs if cfg.stereo_cue else None, cfg.centroid_px,
                                       outlier)
        return log_likelihood

    def _init_source(self, p, cov):
        """The 9-D density the filter (re-)starts from: the candidates' (or the highest
        one's) centres, the last orientation, the nominal semi-axes."""
        sig = self.cfg.orientation_sigma_deg
        if self.cfg.init == "any":
            return importance_function(p, cov, self.orientation, self.cfg, sig)
        k = int(np.argmax(p[:, 2]))
        return importance_function(p[k:k + 1], cov[k:k + 1], self.orientation, self.cfg, sig)

    def step(self, left: CameraImage, right: CameraImage, rng: np.random.Generator
             ) -> GestResult:
        cfg = self.cfg
        views = [hand_view(f, cfg.bins, self.lut) for f in (left, right)]
        blobs = [skin_blobs((v.skin > 0.5).astype(np.uint8), subsample=cfg.blob_subsample)
                 for v in views]
        p, cov, cen, pairs = stereo_candidates(blobs[0], blobs[1], left.camera, right.camera,
                                        cfg.max_epipolar_px, cfg.blob_size,
                                        cfg.blob_sigma_scale, cfg.centroid_px)
        if not self.locked:
            if len(p) == 0:
                return GestResult(None, None, "searching", p, math.nan)
            self.pf.initialize(rng, self._init_source(p, cen if cfg.init_centroid else cov))
            self.locked = True
        importance = None
        if len(p):
            floor = cov + POSITION_FLOOR_M ** 2 * np.eye(3)
            importance = CandidateProposal(
                Mixture(tuple(Gaussian(pj, cj) for pj, cj in zip(p, floor, strict=True))),
                self.pf.particles, self.pf.log_weights, self.walk, self.orientations,
                cfg.fresh_orientation)
        s = self.pf.step(self._ll(views, pairs), rng, importance=importance)
        mean = s.mean.copy()
        mean[6:] = np.maximum(mean[6:], 1e-3)
        proj = project_hands(mean[None], views[0], cfg.n_points)
        d = float(shape_distance(proj, views[0])[0])
        support = len(p) > 0 and float(np.min(np.linalg.norm(p - mean[:3], axis=1))) <= cfg.lost_m
        self.unsupported = 0 if support else self.unsupported + 1
        status = ("tracking" if (s.ok and proj.valid[0] and d <= cfg.lost_px
                                 and self.unsupported < cfg.lost_frames) else "lost")
        if status == "tracking":
            self.orientation = mean[3:6]
            h = patch_histogram(mean, views[0])
            self.ref = h if self.ref is None else update_reference(self.ref, h, cfg.kappa)
        elif len(p):                                 # automatic re-initialisation (Fig. 11)
            self.pf.initialize(rng, self._init_source(p, cen if cfg.init_centroid else cov))
        return GestResult(mean, self.pf.cov, status, p, d)
