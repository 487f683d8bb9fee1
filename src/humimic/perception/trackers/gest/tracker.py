"""GEST, Menezes et al.'s 3-D hand tracker (sec. 6.1, Table 5), for one stereo frame at a time.

State (eq. 16): the hand ellipsoid's centre (robot base frame, m), orientation (yaw pitch
roll, rad) and semi-axes (m); independent Gaussian random walks (Table 5's sigmas) with a small
chance of re-appearing anywhere in the workspace (:class:`.proposal.PoseReset`, so that
particles the importance function proposes after the hand left the view keep their weight).
ICONDENSATION (:func:`humimic.estimation.particles.icondensation_step`) mixes ``alpha``
particles from the stereo importance function (:mod:`.stereo`, :class:`.proposal.
CandidateProposal`), ``beta`` from the dynamics and the rest from the prior; the likelihood
is :mod:`.likelihood`'s (shape, colour and skin cues in the left image, the stereo cue in
both).

The importance function places the centre at each full-resolution skin blob pair's
triangulation, corrected by the last estimate's silhouette offset (the outline of an
ellipsoid is not centred on the image of its centre), with eq. 17's covariance for the
*centroid's* error (``proposal_px``; the paper's inertia, ``proposal: blob``, spreads the
particles over decimetres of depth); while tracking it proposes only the candidates within
``gate_m`` of the estimate, so the other hand is not taken for this one when it leaves.
Blobs cut by the image border are no candidates. Initialisation is automatic: the filter
starts from the highest candidate (``init``), and re-starts after a loss from a candidate
near where the hand was last tracked (``reacquire_m``; any after ``reacquire_frames``).
The estimate is ``lost`` when its centre leaves the left image, its contour is off the edges
by more than ``lost_px`` while its rim does not separate skin from background either (the
skin inside at least ``lost_rim_odds`` times the outside, :func:`.loss.rim_fits`), or
``lost_frames`` frames pass without a candidate within ``lost_m``. The contour test judges
the *published* estimate (the Kalman centre below, not the particles' mean) and whether a
hand-sized ellipse in *any* pose fits there (:func:`.loss.any_pose_fits`): it asks whether
the hand is where GEST says, not whether the orientation estimate is right. The cue images
are computed in a box around the candidates and the last estimate (:mod:`.roi`). The
published centre is, by default (``position: kalman``), not the particles' mean but the
centre's Gaussian posterior given the stereo measurements under the random walk (a Kalman
update per frame: every particle shares the measurement and the linear dynamics of the
centre, so its conditional posterior is one Gaussian; the weights, collapsed by the
orientation and size cues, would otherwise make the estimate one random draw). The published
orientation is the particles' mean rotation modulo the ellipsoid's symmetries
(:func:`.ellipsoid.mean_orientation`), not the mean of their angles.
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
    normalize,
)
from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.histograms import update_reference
from humimic.perception.cues.importance import Blobs
from humimic.perception.trackers.gest.blobs import hand_blobs
from humimic.perception.trackers.gest.config import GestConfig
from humimic.perception.trackers.gest.ellipsoid import mean_orientation
from humimic.perception.trackers.gest.likelihood import (
    hand_log_likelihood,
    hand_view,
    project_views,
    reference_histogram,
    shape_distance,
)
from humimic.perception.trackers.gest.loss import any_pose_fits, lost_threshold_px, rim_fits
from humimic.perception.trackers.gest.proposal import CandidateProposal, PoseReset
from humimic.perception.trackers.gest.roi import (
    crop_frame,
    decimated_camera,
    decimation,
    roi_box,
    to_view_px,
)
from humimic.perception.trackers.gest.silhouette import equivalent_radius, sphere_offset
from humimic.perception.trackers.gest.stereo import (
    interior_blobs,
    stereo_candidates,
)
from humimic.sensors.camera_model import CameraImage


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
    """Mean contour distance of the published estimate's ellipse to the edges (left image,
    px)."""


def skin_mask(image: np.ndarray, lut: ColorLUT) -> np.ndarray:
    return lut.mask(image, 0.5)


def hand_prior(cfg: GestConfig) -> UniformBox:
    spread = np.asarray(cfg.axes) * cfg.axes_spread
    lo = np.r_[cfg.workspace_low, -math.pi, -math.pi / 2, -math.pi, np.asarray(cfg.axes) - spread]
    hi = np.r_[cfg.workspace_high, math.pi, math.pi / 2, math.pi,
               np.asarray(cfg.axes) + spread + 1e-6]
    return UniformBox(lo, hi)


def importance_function(p: np.ndarray, cov: np.ndarray, orientation: np.ndarray,
                        cfg: GestConfig, orientation_sigma_deg: float) -> Mixture | None:
    """A 9-D start density: one Gaussian per stereo candidate (position covariance ``cov``),
    about ``orientation`` for the angles and the nominal semi-axes."""
    if len(p) == 0:
        return None
    o = math.radians(orientation_sigma_deg) ** 2
    a = (np.asarray(cfg.axes) * cfg.axes_spread / 2.0) ** 2
    parts = []
    for pj, cj in zip(p, cov, strict=True):
        C = np.zeros((9, 9))
        C[:3, :3] = cj
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
        self.pf = ParticleFilter("icondensation", dynamics, self.prior, cfg.n_particles, cfg.alpha,
                                 cfg.beta)
        self.ref: np.ndarray | None = None
        self.orientation = np.zeros(3)
        self.locked = False
        self.last: np.ndarray | None = None
        """The last estimate while tracking (None when lost)."""
        self.unsupported = 0
        """Consecutive frames without a stereo candidate near the estimate."""
        self.anchor: np.ndarray | None = None
        """Where the hand was last tracked."""
        self.lost_for = 0
        """Frames since the hand was last tracked."""
        self.offset = np.zeros(3)
        self.centre: tuple[np.ndarray, np.ndarray] | None = None
        """The centre's Gaussian posterior ``(mean, cov)`` (``position: kalman``)."""
        """The last estimate's silhouette offset (:meth:`_silhouette_offset`)."""

    def _ll(self, views, pairs, K, k: int = 1):
        """The likelihood over ``views`` (decimated by ``k``: the stereo cue's sigma and
        outlier density in its pixels, the same cue as at full resolution)."""
        cfg = self.cfg
        w, h = K.width, K.height
        outlier = cfg.stereo_outlier / float(w * h) ** 2
        sigma_px = cfg.centroid_px
        if k > 1:
            outlier, sigma_px = outlier * float(k) ** 4, sigma_px / k

        def log_likelihood(x: np.ndarray) -> np.ndarray:
            x = x.copy()
            x[:, 6:] = np.maximum(x[:, 6:], 1e-3)
            return hand_log_likelihood(x, views, self.ref, cfg.n_points, cfg.sigma_s,
                                       cfg.sigma_c, cfg.sigma_k, cfg.views,
                                       pairs if cfg.stereo_cue else None, sigma_px,
                                       outlier)
        return log_likelihood

    def _init_source(self, p, cov):
        """The 9-D density the filter (re-)starts from: the candidates' centres, the last
        orientation, the nominal semi-axes."""
        return importance_function(p, cov, self.orientation, self.cfg,
                                   self.cfg.orientation_sigma_deg)

    def _silhouette_offset(self, mean: np.ndarray, cams) -> np.ndarray:
        """``x - g(c_L(x), c_R(x))``: the estimate's centre minus the triangulation of its
        outlines' centres in the cameras ``cams`` (an ellipsoid's outline is not centred on
        the image of its centre: 0.3-0.5 px here, centimetres of depth), for the sphere of
        its semi-axes' RMS (:mod:`.silhouette`: the orientation's part is not known); zero
        where undefined or over 5 cm."""
        off = sphere_offset(mean[:3], equivalent_radius(mean[6:9]), *cams)
        return off if np.isfinite(off).all() and np.linalg.norm(off) < 0.05 else np.zeros(3)

    def _reacquire(self, p: np.ndarray) -> np.ndarray:
        """Indices of the candidates the filter may (re-)start from: the highest one (``init:
        raised``) or all (``any``); after a loss only those within ``reacquire_m`` of where
        the hand was last tracked (it re-enters where it left; the other hand, hanging, is
        not taken for it) until ``reacquire_frames`` frames have passed."""
        idx = np.arange(len(p))
        if self.anchor is not None and self.lost_for < self.cfg.reacquire_frames:
            idx = idx[np.linalg.norm(p - self.anchor, axis=1) <= self.cfg.reacquire_m]
        if len(idx) and self.cfg.init == "raised":
            idx = idx[[int(np.argmax(p[idx, 2]))]]
        return idx

    def step(self, left: CameraImage, right: CameraImage, rng: np.random.Generator,
             silhouette_offset: bool = True, foveal: bool = False) -> GestResult:
        """One stereo frame; ``silhouette_offset`` False: the candidates are taken as the
        hand's centre (no :meth:`_silhouette_offset`); ``foveal``: the frames are the foveal
        pair's (the cue images' pixel budget is ``foveal_cue_radius_px``)."""
        cfg = self.cfg
        frames = (left, right)
        near = [self._near(f) for f in frames]
        k = self._decimation(left, near[0],
                             cfg.foveal_cue_radius_px if foveal else cfg.cue_radius_px)
        blobs = [self._blobs(f, n) for f, n in zip(frames, near, strict=True)]
        p, cov, cen1, pairs = stereo_candidates(blobs[0], blobs[1], left.camera, right.camera,
                                                cfg.max_epipolar_px, cfg.blob_size,
                                                cfg.blob_sigma_scale, 1.0)
        pos_cov = cov if cfg.proposal == "blob" else cfg.proposal_px ** 2 * cen1
        pos_cov = pos_cov + cfg.position_floor ** 2 * np.eye(3)
        if self.last is None:                       # searching or lost: (re-)initialise
            use = self._reacquire(p)
            if len(use) == 0:
                self.lost_for += 1
                status = "lost" if self.locked else "searching"
                mean = None if not self.locked else self.pf.last.mean
                return GestResult(mean, self.pf.cov if self.locked else None, status, p,
                                  math.nan)
            self.pf.initialize(rng, self._init_source(p[use], pos_cov[use]))
            self.locked = True
        else:                                       # tracking: candidates near the hand only
            use = np.flatnonzero(np.linalg.norm(p - self.last[:3], axis=1) <= cfg.gate_m)
        delta = (self.offset if self.last is not None and cfg.proposal == "centroid"
                 else np.zeros(3))
        # cue images where the likelihood looks (the left image only with ``views: 1``;
        # the right camera then only places its ellipse centres for the stereo cue)
        boxes = [self._roi(f, b, pairs[:, i] if len(pairs) else None, n, k)
                 if cfg.roi and i < cfg.views else None
                 for i, (f, b, n) in enumerate(zip(frames, blobs, near, strict=True))]
        views = [hand_view(crop_frame(f, b, k), cfg.bins, self.lut, cfg.edges == "colour")
                 if i < cfg.views
                 else _Geometry(decimated_camera(f.camera, k)) for i, (f, b) in
                 enumerate(zip(frames, boxes, strict=True))]
        origin = np.array([(0, 0) if b is None else b[:2] for b in boxes], float)
        importance = None
        if len(use):
            importance = CandidateProposal(
                Mixture(tuple(Gaussian(p[j] + delta, pos_cov[j]) for j in use)),
                self.pf.particles, normalize(self.pf.log_weights).log_weights, self.walk,
                self.orientations, cfg.fresh_orientation,  # as the filter normalises them
                self.pf.dynamics.densities)
        s = self.pf.step(self._ll(views, to_view_px(pairs, origin[None], k),
                                  left.camera.intrinsics, k), rng, importance=importance)
        mean = s.mean.copy()
        mean[3:6] = mean_orientation(s.particles[:, 3:6], s.log_weights)
        mean[6:] = np.maximum(mean[6:], 1e-3)
        support = len(use) > 0 and float(np.min(np.linalg.norm(p[use] - mean[:3], axis=1))
                                         ) <= cfg.lost_m
        self.unsupported = 0 if support else self.unsupported + 1
        offset = (self._silhouette_offset(mean, (left.camera, right.camera))
                  if silhouette_offset else np.zeros(3))
        centre = self._centre(mean, p, use, cen1, offset)
        if centre is not None:                      # the published centre (module docstring)
            mean[:3] = centre[0]
        # the loss test judges the published estimate, not the particles' mean: with weak
        # grey-level edges (a dark hand over dark clothes) the shape cue pulls the particles
        # onto other edges while the stereo-measured centre stays on the hand
        (proj, _), _ = project_views(mean[None], views, cfg.n_points, 1)
        d = float(shape_distance(proj, views[0])[0])
        limit_px = lost_threshold_px(mean, views[0], cfg.lost_px, cfg.lost_rel)
        fits = proj.valid[0] and (
            d <= limit_px or bool(rim_fits(proj, views[0], cfg.lost_rim_odds)[0])
            or any_pose_fits(mean, proj, views[0], cfg.n_points, limit_px, cfg.lost_rim_odds))
        status = ("tracking" if (s.ok and fits
                                 and _centre_in_image(mean, left)
                                 and self.unsupported < cfg.lost_frames) else "lost")
        if status == "tracking":
            self.orientation = mean[3:6]
            self.last, self.anchor = mean, mean[:3]
            self.lost_for = 0
            self.offset, self.centre = offset, centre
            h = reference_histogram(proj, views[0])
            self.ref = h if self.ref is None else update_reference(self.ref, h, cfg.kappa)
        else:
            self.last, self.centre = None, None
            self.lost_for += 1
            self.unsupported = 0
        return GestResult(mean, self.pf.cov, status, p, d)

    def _centre(self, mean: np.ndarray, p: np.ndarray, use: np.ndarray, cen1: np.ndarray,
                offset: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The centre's Gaussian posterior ``(mean, cov)`` after this frame (``position:
        kalman``; None otherwise): the last one updated with the candidate nearest the
        particles' mean (corrected by the silhouette ``offset``, covariance from
        ``centroid_px``), or only predicted under the random walk without a candidate."""
        cfg = self.cfg
        if cfg.position != "kalman":
            return None
        if len(use):
            j = use[int(np.argmin(np.linalg.norm(p[use] - mean[:3], axis=1)))]
            z, R = p[j] + offset, cfg.centroid_px ** 2 * cen1[j]
            return (z, R) if self.centre is None else centre_update(
                *self.centre, z, R, cfg.sigma_position)
        if self.centre is None:
            return None
        return self.centre[0], self.centre[1] + cfg.sigma_position ** 2 * np.eye(3)

    def _near(self, frame: CameraImage) -> tuple[np.ndarray, float] | None:
        """The last estimate's centre in ``frame`` (px) and its distance from the camera (m),
        None when there is no estimate (both cue boxes are placed around it)."""
        if self.last is None:
            return None
        uv = frame.camera.project_base(self.last[:3])
        return uv, float(np.linalg.norm(self.last[:3] - frame.camera.T_base_cam[:3, 3]))

    def _decimation(self, frame: CameraImage, near: tuple[np.ndarray, float] | None,
                    budget_px: float | None) -> int:
        """The block size the frame's cue images are computed at (pixel budget
        ``budget_px``): from the last estimate's image radius in ``frame`` (1 without an
        estimate)."""
        if near is None or budget_px is None:
            return 1
        r = frame.camera.intrinsics.fx * float(np.max(self.last[6:])) / max(near[1], 0.05)
        return decimation(r, budget_px)

    def _blobs(self, frame: CameraImage, near: tuple[np.ndarray, float] | None) -> Blobs:
        """The frame's skin blobs that are not cut by the image border; while tracking, only
        in the box the gate projects to around the last estimate (blobs cut by that box too
        are dropped): the candidates outside it would be gated out anyway."""
        cfg = self.cfg
        box = None
        if near is not None and cfg.roi:
            K = frame.camera.intrinsics
            uv, depth = near
            r = K.fx * (cfg.gate_m + float(self.last[6:].max())) / max(depth, 0.05)
            if np.isfinite(uv).all():
                box = roi_box(np.array([[uv[0] - r, uv[1] - r, 2 * r, 2 * r]]), K.width,
                              K.height, 0.0)
        h, w = frame.image.shape[:2]
        x0, y0, x1, y1 = (0, 0, w, h) if box is None else box
        b = interior_blobs(hand_blobs(frame.image, self.lut, cfg.blob_subsample,
                                      min_area_px=cfg.blob_min_area_px, box=box),
                           x1 - x0, y1 - y0, cfg.border_px)
        if box is None:
            return b
        shift = np.array(box[:2], float)
        return Blobs(b.centers + shift, b.boxes + (box[0], box[1], 0.0, 0.0), b.areas)

    def _roi(self, frame: CameraImage, blobs, centroids, near: tuple[np.ndarray, float] | None,
             k: int = 1) -> tuple[int, int, int, int] | None:
        """The box the cues are computed in (:mod:`.roi`): the hand-sized blobs matched in
        stereo, the blobs near the last estimate, padded by ``cue_pad_px`` (in the pixels of
        the cue images, decimated by ``k``)."""
        K = frame.camera.intrinsics
        boxes = [blobs.boxes[_matched(blobs, centroids)]]
        if near is not None:
            uv, depth = near
            r = 1.5 * K.fx * float(np.max(self.last[6:])) / max(depth, 0.05)
            boxes.append(np.array([[uv[0] - r, uv[1] - r, 2 * r, 2 * r]]))
        box = roi_box(np.concatenate(boxes), K.width, K.height, self.cfg.cue_pad_px * k)
        return box if box is not None else (0, 0, K.width, K.height)


def centre_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray, sigma: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """One Kalman cycle of the centre: the random walk ``x_k = x_{k-1} + N(0, sigma^2 I)``
    (eq. 16's dynamics), then the direct measurement ``z = x_k + N(0, R)``."""
    P = P + sigma ** 2 * np.eye(3)
    K = P @ np.linalg.inv(P + R)
    return x + K @ (z - x), (np.eye(3) - K) @ P


def _matched(blobs, centroids) -> np.ndarray:
    """Indices of ``blobs`` whose centre is one of ``centroids (M, 2)``."""
    if centroids is None or len(blobs.areas) == 0:
        return np.zeros(0, int)
    d = np.linalg.norm(blobs.centers[:, None] - centroids[None], axis=2)
    return np.flatnonzero(d.min(axis=1) < 1e-6)


def _centre_in_image(state: np.ndarray, frame: CameraImage) -> bool:
    """Whether the state's centre is in front of the camera and projects into the image."""
    return bool(frame.camera.intrinsics.contains(frame.camera.project_base(state[:3])))


@dataclass(frozen=True)
class _Geometry:
    """A camera's geometry in the form :func:`.likelihood.project_hands` reads."""

    cam: object

    @property
    def intrinsics(self):
        return self.cam.intrinsics

    @property
    def T_cam_base(self):
        return self.cam.T_cam_base
