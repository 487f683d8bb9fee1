"""TBP, Menezes et al.'s two-arm tracker (secs. 6.2-6.3, Table 6), one monocular frame at a
time.

State: ``x' = [q_k, q_{k-1}]`` (16 values, ``q`` the eight arm angles ``R_SFE ... L_EB``),
constant-velocity AR dynamics ``x'_k = A x'_{k-1} + w_k`` (``q_k = 2 q_{k-1} - q_{k-2} +
w``). The auxiliary particle filter (:func:`humimic.estimation.particles.apf_step`, Table 2)
picks predecessors by the skin cue of their predicted hands (first stage) and weights the new
particles by eq. 19 (second stage, :mod:`.likelihood`). Samples outside the joint limits are
clamped to them, not rejected. Cue weights are set on the first frame: ``lambda_s`` from the
edge density around the person (plain or cluttered), each patch's ``lambda_c`` from how far
its reference histogram is from a uniform one. If every particle has zero likelihood the set
restarts from the rest pose.
"""

from __future__ import annotations

import math

import numpy as np

from humimic.bodymodel.kinematics import ARM_DOFS
from humimic.bodymodel.model import BodyModel
from humimic.bodymodel.projection import project
from humimic.estimation.particles import LinearGaussian, apf_step, weighted_cov
from humimic.estimation.particles.weights import uniform_log_weights
from humimic.perception.cues.edges import sample, shape_log_likelihood
from humimic.perception.cues.histograms import bhattacharyya
from humimic.perception.cues.importance import skin_blobs
from humimic.perception.cues.motion import OpticalFlow
from humimic.perception.trackers.tbp.config import TbpConfig
from humimic.perception.trackers.tbp.likelihood import (
    ArmView,
    arm_view,
    full_log_likelihood,
    hand_interiors,
    patch_histograms_all,
    project_arms,
    skin_distance,
)
from humimic.perception.trackers.tbp.reinit import (
    arm_table,
    draw_arms,
    hand_centres,
    hand_pixels,
    head_circle,
    near_blobs,
)

ARM_NAMES = ARM_DOFS["R"] + ARM_DOFS["L"]


def cv_dynamics(n: int, sigma: float, keep: float = 1.0) -> LinearGaussian:
    """Constant-velocity AR model on ``[q_k, q_{k-1}]`` (Menezes sec. 6.3.1, ``x'_k = A
    x'_{k-1} + w_k``; ``n`` angles, noise ``sigma`` rad on ``q_k``; a negligible one on the
    copied ``q_{k-1}`` keeps ``Q`` positive definite). ``keep < 1`` damps the velocity:
    ``q_k = q_{k-1} + keep (q_{k-1} - q_{k-2}) + w``."""
    I, Z = np.eye(n), np.zeros((n, n))
    F = np.block([[(1 + keep) * I, -keep * I], [I, Z]])
    Q = np.diag(np.r_[np.full(n, sigma ** 2), np.full(n, 1e-12)])
    return LinearGaussian(F, Q)


def surround_edge_density(body: BodyModel, q: np.ndarray, torso: np.ndarray,
                          view: ArmView) -> float:
    """Edge-pixel fraction in the person's surroundings: the box around the body model's
    projection at ``q`` widened by half its height on each side and above (the background the
    arms move over, the person's own outline included)."""
    bv = project(body, body.forward(q, fixed=torso), view.intrinsics, view.T_cam_base)
    uv = bv.outline.uv[0].reshape(-1, 2)
    uv = uv[np.isfinite(uv).all(axis=1)]
    edges = view.maps.edges > 0
    h, w = edges.shape
    (u0, v0), (u1, v1) = uv.min(axis=0), uv.max(axis=0)
    m = 0.5 * (v1 - v0)
    box = edges[max(0, int(v0 - m)):min(h, int(v1)), max(0, int(u0 - m)):min(w, int(u1 + m))]
    return float(box.mean()) if box.size else view.edge_density


class TbpTracker:
    def __init__(self, cfg: TbpConfig, body: BodyModel, lut):
        self.cfg, self.body, self.lut = cfg, body.with_free(ARM_NAMES), lut
        self.hands = self.body.without(*[p for p in self.body.part_names
                                         if p not in ("r_hand", "l_hand")])
        self.q_def = np.radians(np.tile(cfg.rest_deg, 2))
        self.dynamics = cv_dynamics(8, math.radians(cfg.sigma_deg), cfg.velocity_keep)
        self.flow = OpticalFlow()
        self.prev_image = None
        self.particles: np.ndarray | None = None
        self.log_weights: np.ndarray | None = None
        self.refs: np.ndarray | None = None
        self.weights: dict | None = None
        self.restarts = 0
        self.last_view: ArmView | None = None
        self.table = None
        self.frames_without_refs = 0
        self.found = np.zeros(2, bool)
        """Whether the last estimate's right, left hand lay on skin."""
        self.hand_uv = np.full((2, 2), np.nan)
        """The last estimate's right, left hand centres in the image (px), NaN where the hand
        did not lie on skin."""
        self.injected = 0
        """Particles drawn from the skin blobs so far (:meth:`_from_blobs`)."""

    def _start(self, rng: np.random.Generator) -> None:
        q = self.body.clamp(self.q_def + rng.normal(0, math.radians(self.cfg.init_sigma_deg),
                                                    (self.cfg.n_particles, 8)))
        self.particles = np.hstack([q, q])
        self.log_weights = uniform_log_weights(self.cfg.n_particles)

    def _first_frame(self, view: ArmView, torso: np.ndarray, q: np.ndarray | None = None) -> None:
        """Cue weights from the first frame (sec. 6.3.1) and the patches' references (under
        the arms at ``q``, default the rest pose)."""
        cfg = self.cfg
        q0 = self.q_def[None]
        density = surround_edge_density(self.body, q0, torso, view)
        cluttered = density > cfg.edge_density
        q_ref = q0 if q is None else q[None]
        refs = patch_histograms_all(project_arms(self.body, q_ref, torso, view, 4),
                                    view.qimage)[0]
        uniform = np.full(refs.shape[-1], 1.0 / refs.shape[-1])
        d_uniform = bhattacharyya(refs, uniform).mean(axis=-1)                # (6,)
        lam_c = np.where(d_uniform < cfg.patch_confidence, cfg.lambda_c[1], cfg.lambda_c[0])
        self.refs = refs
        self.weights = {"lambda_s": cfg.lambda_s[1] if cluttered else cfg.lambda_s[0],
                        "sigma_s": cfg.sigma_s, "K": cfg.K, "cap_px": cfg.cap_px,
                        "sigma_c": cfg.sigma_c,
                        "lambda_c": lam_c, "sigma_k": cfg.sigma_k, "lambda_st": cfg.lambda_st,
                        "lambda_co": cfg.lambda_co, "q_def": self.q_def,
                        "cluttered": bool(cluttered), "edge_density": density}

    def _from_blobs(self, view: ArmView, torso: np.ndarray, rng: np.random.Generator) -> None:
        """Re-draw ``reinit_fraction`` of the particles' arms from configurations whose hand
        projects onto a skin blob (:mod:`.reinit`), for the arms whose hand the last estimate
        did not find on skin; blobs on the face are left out, and so is, for each arm, the
        blob the last estimate's *other* hand lies on (found, or sharing a blob with this
        one): the other arm's particles hold it, and offering it drew the lost arm onto the
        other hand -- fig13_tbp_wave seed 4: the right arm, lagging behind the raised hand,
        took the left hand's blob at 1.07 s and stayed there for 2.8 s (both hands on one
        blob score 1-3 nats above the true raised arm under eq. 19, the stabiliser's pull).
        The arm's own blob stays offered (other depths along its line of sight; leaving it
        out too cost the wave under way at the start 2-8 deg on 4 of 5 replays).
        """
        cfg = self.cfg
        n = int(round(cfg.reinit_fraction * cfg.n_particles))
        if n == 0 or view.skin is None or self.found.all():
            return
        if self.table is None:
            self.table = arm_table(self.body, cfg.reinit_table, rng)
        blobs = skin_blobs(view.skin > 0.5, 1, cfg.reinit_min_area_px, (0.2, 5.0))
        if not len(blobs.areas):
            return
        pose = self.body.forward(self.q_def[None], fixed=torso)
        head_uv, head_r = head_circle(self.body, pose, view.intrinsics, view.T_cam_base)
        hand = np.linalg.norm(blobs.centers - head_uv, axis=1) > head_r
        if not hand.any():
            return
        centres = blobs.centers[hand]
        radius = np.sqrt(blobs.areas[hand] / np.pi) + cfg.reinit_radius_px
        on = near_blobs(self.hand_uv, centres, radius)      # the estimate's hands per blob
        R_t, p_t = pose.segment("torso")
        uv = hand_pixels(self.table, R_t[0], p_t[0], view.intrinsics, view.T_cam_base)
        groups = [(side, m) for side in (0, 1) if not self.found[side]
                  for m, hands in zip(near_blobs(uv[side], centres, radius), on, strict=True)
                  if len(m) and 1 - side not in hands]
        if not groups:
            return
        self.particles, _ = draw_arms(self.particles, self.table, groups, n,
                                      math.radians(cfg.init_sigma_deg) / 4, rng)
        self.injected += n

    def _hands_found(self, q: np.ndarray, torso: np.ndarray, view: ArmView) -> np.ndarray:
        """``(2,)`` bool: the right, left hand of the arms at ``q`` lies on skin (mean skin
        posterior inside the hand's outline at least ``hands_found_skin``), not on the face
        (its centre outside the head's image circle) and not on the other hand (the centres
        at least a hand's image width apart: one arm crossed over to the other's hand would
        otherwise count as found and never be re-drawn)."""
        inner = hand_interiors(self.hands, q[None], torso, view)
        on_skin = sample(view.skin, inner, 0.0).mean(axis=2)[0] >= self.cfg.hands_found_skin
        pose = self.body.forward(q[None], fixed=torso)
        head_uv, head_r = head_circle(self.body, pose, view.intrinsics, view.T_cam_base)
        p_cam = hand_centres(self.body, pose)[:, 0] @ view.T_cam_base[:3, :3].T
        p_cam += view.T_cam_base[:3, 3]
        uv = view.intrinsics.project(p_cam)
        self.hand_uv = np.where(on_skin[:, None], uv, np.nan)
        hand_px = 2.0 * view.intrinsics.fx * max(self.body.part("r_hand").shape.semi_axes)
        apart = np.linalg.norm(uv[0] - uv[1]) > hand_px / np.min(p_cam[:, 2])
        return on_skin & (np.linalg.norm(uv - head_uv, axis=1) > head_r) & apart

    def step(self, frame, torso: np.ndarray, rng: np.random.Generator):
        """One frame: returns ``(mean (8,), cov (8, 8), ok)``."""
        cfg = self.cfg
        flow = None if self.prev_image is None else self.flow(self.prev_image, frame.image)
        self.prev_image = frame.image
        view = self.last_view = arm_view(frame, flow, self.lut, cfg.bins,
                                         cfg.edges == "colour", cfg.patch_colours)
        if self.particles is None:
            self._start(rng)
            self._first_frame(view, torso)
            if cfg.patch_refs == "first_estimate":
                self.refs = None                     # the first step without colour patches
        body, w, refs = self.body, self.weights, self.refs
        self._from_blobs(view, torso, rng)

        def first(x):                                           # skin cue of the hands
            inner = hand_interiors(self.hands, body.clamp(x[:, :8]), torso, view)
            return shape_log_likelihood(skin_distance(inner, view.skin),
                                        cfg.sigma_k_first or cfg.sigma_k)

        def second(x):
            q = body.clamp(x[:, :8])
            proj = project_arms(body, q, torso, view, cfg.n_points)
            return full_log_likelihood(proj, view, q, body, w, refs)

        s = apf_step(self.particles, self.log_weights, self.dynamics, second, rng,
                     first_stage=first)
        x = s.particles.copy()
        x[:, :8] = body.clamp(x[:, :8])                          # clamped, not rejected
        self.particles, self.log_weights = x, s.log_weights
        if not s.ok:
            self.restarts += 1
            self._start(rng)
        mean = body.clamp(s.mean[None, :8])[0]
        self.found = self._hands_found(mean, torso, view)
        if refs is None and cfg.patch_refs == "first_estimate" and s.ok:
            self.frames_without_refs += 1
            if (self.frames_without_refs > cfg.patch_refs_wait
                    or self.found.all()):
                self._first_frame(view, torso, mean)     # references under the estimate
        cov = weighted_cov(x[:, :8], s.log_weights)
        return mean, cov, s.ok
