"""The stateful tracker around the kernel particle filter's pure maths
(:mod:`humimic.estimation.particles.kernel`) and the likelihood (eqs. 9-10).

One frame (Schmidt sec. 5.2): resample the posterior, propagate a share of the particles with
the linear motion model (velocity from the last two best modes) and the rest randomly, seek the
modes by mean shift with reweighting, take the dominant mode as the estimate, set next frame's
motion share from each group's cumulated posterior, and adapt the mean colours from the mode's
back-projection (eq. 7). ``filter: condensation`` runs plain CONDENSATION instead (the same
likelihood; a random walk of the same extent; the weighted mean).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic import bodymodel as bm
from humimic.bodymodel.rom import arm_twist_log_prior
from humimic.estimation.particles import kernel as kpf
from humimic.estimation.particles.densities import Gaussian
from humimic.estimation.particles.filters import condensation_step
from humimic.estimation.particles.kernel_groups import dominant_modes
from humimic.estimation.particles.weights import uniform_log_weights
from humimic.maths.blas import one_blas_thread
from humimic.perception.cues.importance import skin_blobs
from humimic.perception.trackers.kpf import split as sp
from humimic.perception.trackers.kpf.branches import FlipBranches
from humimic.perception.trackers.kpf.cues import CueMaps
from humimic.perception.trackers.kpf.depth import SIDES, kept_ranges, wrist_depth_move
from humimic.perception.trackers.kpf.depth_gate import keep_range_gates
from humimic.perception.trackers.kpf.flips import flip_jumps
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.hands import hand_blob_moves, part_centres
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.refine import refine_arms
from humimic.perception.trackers.kpf.velocity import (
    arm_noise_shaping,
    observable_arm_velocity,
    particle_velocities,
)

#: The state's partition (``partitioned``): torso, right arm, left arm DOFs.
GROUPS = [np.arange(0, 6), np.arange(6, 10), np.arange(10, 14)]
#: Mean-shift modes reported per frame (the heaviest distinct ones), for display.
MAX_MODES = 8
#: The kernel sums' precision (:func:`~humimic.estimation.particles.kernel.kpf_modes`): single
#: precision halves the memory traffic of the N x N kernel matrices; its relative error (~1e-6
#: on centred, bandwidth-scaled coordinates) is far below the particles' spread.
KERNEL_DTYPE = np.float32


@dataclass(frozen=True)
class ClampedWalk:
    """CONDENSATION's dynamics: uniform noise of half-width ``D`` (as the KPF's random group),
    clamped into the joint limits."""

    D: np.ndarray
    limits: bm.JointLimits

    def sample(self, x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        return self.limits.clamp(x + rng.uniform(-1.0, 1.0, x.shape) * self.D)

    def log_density(self, x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        raise NotImplementedError("CONDENSATION samples from the dynamics only")

    def mean(self, x: np.ndarray) -> np.ndarray:
        return x


@dataclass(frozen=True)
class FrameResult:
    mode: np.ndarray
    """(14,) the estimate."""
    particles: np.ndarray
    weights: np.ndarray
    spread: np.ndarray
    """(14,) weighted standard deviation of the particles."""
    lost: bool
    cost: float
    """Mean cue cost of the estimate."""
    iterations: int
    modes: np.ndarray
    """(M, 14) distinct mean-shift modes (the particles' converged positions, deduplicated)."""


def motion_velocity(mode: np.ndarray, mode_prev: np.ndarray, torso: bool = True) -> np.ndarray:
    """Schmidt sec. 5.2's linear motion model's velocity, the last two best modes' difference
    ``(14,)``; ``torso=False`` (``KpfConfig.torso_velocity``): zero on the torso's DOFs."""
    v = np.asarray(mode, float) - np.asarray(mode_prev, float)
    if not torso:
        v[GROUPS[0]] = 0.0
    return v


def distinct(fn):
    """``fn`` over particles, evaluated once per distinct particle: mean shift moves whole
    windows of particles onto the same point (20-80 % duplicates after the first shift), so
    this saves that share of the likelihood evaluations. (``sigma_from_spread`` then takes
    the spread over the distinct particles.)"""
    def f(q: np.ndarray) -> np.ndarray:
        first, inverse = kpf.unique_rows(q)
        return np.asarray(fn(q[first]))[inverse]
    return f


def kpf_body(model=None) -> bm.BodyModel:
    """Schmidt's 14-DOF model of the avatar (elliptic-cylinder torso), the torso's yaw free
    over +-360 deg (a person facing the robot has yaw 180 deg in the base frame: a +-180 deg
    limit would clamp half the particles)."""
    from humimic.world.names import HUMAN_PREFIX

    limits = bm.JointLimits.default(torso_yaw=(-2 * np.pi, 2 * np.pi))
    if model is None:
        return bm.avatar_body(limits=limits, torso="cylinder")
    return bm.avatar_body(model, HUMAN_PREFIX, limits=limits, torso="cylinder")


class KpfTracker:
    """Schmidt et al.'s 14-DOF upper-body tracker; ``cfg`` a
    :class:`~humimic.perception.trackers.kpf.config.KpfConfig`, ``frame_rate`` the camera's
    (scales D, see ``KpfConfig.D_rate``)."""

    def __init__(self, body: bm.BodyModel, intrinsics, cfg, rng: np.random.Generator,
                 frame_rate: float | None = None, lik: Likelihood | None = None):
        self.body, self.cfg, self.rng = body, cfg, rng
        self.lik = Likelihood(body, intrinsics, cfg) if lik is None else lik
        self.D = np.asarray(cfg.D(frame_rate), float)
        self.limits = body.free_limits
        self.groups = (sp.split_groups(bm.DOF_NAMES) if cfg.split_arms else GROUPS) \
            if cfg.partitioned else [np.arange(len(self.D))]
        self.split = cfg.split_resample if cfg.split_arms else None
        self.particles: np.ndarray | None = None
        self.w = np.zeros(0)
        self.mode = self.mode_prev = None
        self.share = 0.5
        self.torso_prior: Gaussian | None = None
        self.best_prev: float | None = None
        """The last frame's best log-likelihood (``rescue_passes``)."""
        self.branches = None if cfg.branch_threshold is None or cfg.filter != "kpf" else \
            FlipBranches(body, intrinsics, cfg)

    def start(self, q0: np.ndarray, maps: CueMaps | FrameCues, T_cam_base: np.ndarray) -> None:
        """Initialise at a known pose (the paper fits the model by hand): every particle at
        ``q0`` and the colour references from its back-projection."""
        n = self.cfg.n_particles
        self.mode = self.mode_prev = self.limits.clamp(np.asarray(q0, float))
        self.pvel = np.zeros((n, len(self.mode)))
        c = self.cfg
        self.torso_prior = None if c.torso_prior_m is None else Gaussian(
            self.mode[:6], np.diag([c.torso_prior_m ** 2] * 3
                                   + [np.radians(c.torso_prior_deg) ** 2] * 3))
        self.particles = np.repeat(self.mode[None], n, axis=0)
        self.w = np.full(n, 1.0 / n)
        self.W = np.full((n, max(len(self.groups), 3)), 1.0 / n)
        self.lik.adapt({p: c[0] for p, c in
                        self.lik.evaluate(self.mode[None], maps, T_cam_base).colours.items()})

    def _prior(self, q: np.ndarray) -> np.ndarray:
        """Log-prior of the torso pose (0 without ``torso_prior_m``)."""
        return 0.0 if self.torso_prior is None else self.torso_prior.log_density(q[:, :6])

    def _arm_prior(self, q: np.ndarray) -> np.ndarray:
        """``(N, 2)`` log-prior of each arm's (R, L) humeral twist (0 without
        ``twist_range_deg``)."""
        if self.cfg.twist_range_deg is None:
            return np.zeros((len(q), len(SIDES)))
        lo, hi = np.radians(self.cfg.twist_range_deg)
        sd = np.radians(self.cfg.twist_sd_deg)
        return np.column_stack([arm_twist_log_prior(s, *q[:, j:j + 3].T, lo, hi, sd)
                                for s, (_, j) in SIDES.items()])

    def _log_post(self, q, maps, T_cam_base, floors: bool = False) -> np.ndarray:
        """The log-likelihood (eqs. 9-10) plus the torso and twist log-priors of poses ``q``."""
        return (self.lik.evaluate(q, maps, T_cam_base, floors=floors).log_lik
                + self._prior(q) + self._arm_prior(q).sum(1))

    def _log_lik(self, maps, T_cam_base):
        return distinct(lambda q: self._log_post(q, maps, T_cam_base))

    def _group_log_lik(self, maps, T_cam_base):
        """``(N, 3)``: the whole pose's log-likelihood (torso group), the right arm's limbs',
        the left arm's."""
        cols = [self.lik.parts.index(p) for p in self.lik.parts]
        side = [np.array([c for c, p in zip(cols, self.lik.parts, strict=True) if p[:2] == s])
                for s in ("r_", "l_")]

        def f(q):
            t = self.lik.evaluate(q, maps, T_cam_base).terms
            arm = self._arm_prior(q)
            return np.column_stack([t.sum(1) + self._prior(q) + arm.sum(1),
                                    t[:, side[0]].sum(1) + arm[:, 0],
                                    t[:, side[1]].sum(1) + arm[:, 1]])
        return distinct(f)

    def _split_log_lik(self, maps, T_cam_base):
        """``(N, 5)`` (``split_arms``): :func:`.split.split_log_lik`."""
        cols = sp.split_part_columns(self.lik.parts)
        return distinct(lambda q: sp.split_log_lik(self.lik.evaluate(q, maps, T_cam_base).terms,
                                                cols, self._prior(q), self._arm_prior(q)))

    def step(self, maps: CueMaps | FrameCues, T_cam_base: np.ndarray) -> FrameResult:
        """Track one frame (BLAS on one thread: the N x N products are small, and threads
        spinning on a shared 2-core machine made them 5x slower)."""
        if self.particles is None:
            raise RuntimeError("KpfTracker.step before start")
        with one_blas_thread():
            return self._step(maps, T_cam_base)

    def _step(self, maps: CueMaps | FrameCues, T_cam_base: np.ndarray) -> FrameResult:
        if self.cfg.filter == "condensation":
            mode, iters, modes = self._condensation(maps, T_cam_base), 0, None
        else:
            mode, iters, modes = self._kpf(maps, T_cam_base)
            if self.branches is not None:   # our extension: the arms' flip branches
                mode = self.branches.step(self, mode, maps, T_cam_base)
        report = mode
        refined = self.cfg.refine_polls > 0 and self.cfg.filter == "kpf"
        if refined:
            report = self._refine(mode, maps, T_cam_base)
            if self.cfg.refine_feedback:
                mode = report
        ev = self.lik.evaluate(mode[None], maps, T_cam_base)
        cost = ev.mean_cost(0)
        lost = not cost <= self.cfg.lost_cost
        if lost:   # keep the particles; no velocity, no colour adaptation
            self.mode_prev = self.mode
            self.pvel[:] = 0.0
        else:
            self.mode_prev, self.mode = self.mode, mode
            self.lik.adapt({p: c[0] for p, c in ev.colours.items()})
        mean = self.w @ self.particles
        spread = np.sqrt(np.maximum(self.w @ (self.particles - mean) ** 2, 0.0))
        if modes is None:
            modes = mode[None]
        elif refined:    # the reported (refined) mode first, as the display expects
            modes = np.vstack([report[None], modes])[:MAX_MODES]
        return FrameResult(report, self.particles, self.w, spread, lost, cost, iters, modes)

    def _kpf(self, maps, T_cam_base):
        cfg, rng = self.cfg, self.rng
        groups = self.groups
        idx = sp.resample_indices(self.W, groups, self.split, rng)
        resampled = kpf.partitioned_take(self.particles, idx, groups)
        if cfg.particle_velocity:   # each particle's own, carried through the resampling
            velocity = kpf.partitioned_take(self.pvel, idx, groups)
            if not cfg.torso_velocity:
                velocity[:, GROUPS[0]] = 0.0
        else:
            velocity = motion_velocity(self.mode, self.mode_prev, cfg.torso_velocity)
        if cfg.observed_velocity_px is not None:
            velocity = observable_arm_velocity(self.body, self.lik.intr, self.mode, velocity,
                                               T_cam_base, cfg.observed_velocity_px)
        shape = None if cfg.observed_walk_px is None else arm_noise_shaping(
            self.body, self.lik.intr, self.mode, T_cam_base, cfg.observed_walk_px,
            cfg.observed_walk_floor)
        pred, moved = kpf.mixed_propagate(resampled, velocity, self.share, self.D,
                                          rng, self.limits.inside, cfg.motion_noise,
                                          shape=shape,
                                          shape_groups=cfg.observed_walk_groups)
        pred = self.limits.clamp(pred)
        if cfg.keep_range_share > 0.0:   # part of the walk: the reweighting's prior has them
            pred = self._keep_range(pred, resampled, velocity, moved, T_cam_base)
        walked = pred
        if cfg.flip_share > 0.0:   # part of the dynamics: the reweighting's prior has them
            pred = flip_jumps(self.body, pred.copy(), T_cam_base, cfg.flip_share,
                              self.limits, rng)
        prior = pred
        if cfg.depth_share > 0.0:   # a proposal: the reweighting keeps the dynamics' KDE
            pred = self._depth_moves(pred.copy(), T_cam_base, cfg.depth_share)
        if cfg.hand_share > 0.0:    # a proposal too
            pred = self._hand_moves(pred.copy(), maps, T_cam_base, cfg.hand_share)
        lik = (self._log_lik if not cfg.partitioned else self._split_log_lik if cfg.split_arms
               else self._group_log_lik)(maps, T_cam_base)
        parts, W, ll, iters = kpf.kpf_modes(pred, lik, self.D, cfg.iterations, cfg.tol,
                                            cfg.shrink, cfg.reweight == "kernel", groups,
                                            cfg.kde_stride, prior, KERNEL_DTYPE)
        best, rescued = float(np.max(ll[:, 0])), False
        for _ in range(cfg.rescue_passes):
            # the best particle fell well below the last frame's: the search lost the pose
            # (fast motion); search again from this frame's posterior, a random walk of extent
            # D, and mean shift
            if self.best_prev is None or best >= self.best_prev - cfg.rescue_drop:
                break
            again = kpf.partitioned_take(parts, sp.resample_indices(W, groups, self.split, rng),
                                         groups)
            again = self.limits.clamp(again + rng.uniform(-1.0, 1.0, again.shape) * self.D)
            if cfg.rescue_depth_share > 0.0:
                again = self._depth_moves(again, T_cam_base, cfg.rescue_depth_share)
            p2, W2, ll2, it2 = kpf.kpf_modes(again, lik, self.D, cfg.iterations, cfg.tol,
                                             cfg.shrink, cfg.reweight == "kernel", groups,
                                             cfg.kde_stride, dtype=KERNEL_DTYPE)
            iters += it2
            if float(np.max(ll2[:, 0])) > best:
                parts, W, ll, best = p2, W2, ll2, float(np.max(ll2[:, 0]))
                rescued = True
        self.best_prev = best
        h = cfg.shrink ** max(iters - 1, 0) * self.D
        win = cfg.window * self.D
        mode = dominant_modes(parts, W, h, win, groups, KERNEL_DTYPE)
        w = W[:, 0]
        self.share = kpf.motion_share(w, moved, cfg.min_random)
        # each particle's velocity: from its ancestor to where mean shift took it (none when a
        # rescue pass replaced the set: those particles have other ancestors; none for a
        # particle a flip, depth or hand jump moved: a jump is not a motion to repeat)
        if cfg.particle_velocity:   # only then read: no per-frame work without it
            self.pvel = np.zeros_like(parts) if rescued else particle_velocities(
                parts, resampled, walked, velocity, moved, cfg.particle_velocity_innovation,
                cfg.particle_velocity_decay)
            self.pvel[np.any(pred != walked, axis=1)] = 0.0
        self.particles, self.w, self.W = parts, w, W
        first, _ = kpf.unique_rows(np.round(parts / (cfg.window * self.D)))
        return mode, iters, parts[first[np.argsort(-w[first])][:MAX_MODES]]

    def _refine(self, mode: np.ndarray, maps, T_cam_base: np.ndarray) -> np.ndarray:
        """``refine_polls``: the mode moved uphill on the likelihood (the sigmas' floors) and
        priors by a pattern search per arm (:func:`~humimic.perception.trackers.kpf.refine.
        refine_arms`); with ``refine_feedback`` it replaces the lightest particle, weighted as
        the heaviest."""
        cfg = self.cfg

        def f(q):
            return self._log_post(q, maps, T_cam_base, floors=True)
        new, _ = refine_arms(self.body, mode, f, self.D, T_cam_base, cfg.refine_polls,
                             cfg.refine_step, cfg.refine_depth_m, self.limits)
        if cfg.refine_feedback:
            k = int(np.argmin(self.w))
            self.particles = self.particles.copy()
            self.particles[k] = new
            self.pvel = self.pvel.copy()    # no velocity of its own (not the replaced one's)
            self.pvel[k] = 0.0
            self.W = self.W.copy()
            self.W[k] = self.W.max(axis=0)
            self.W /= self.W.sum(axis=0, keepdims=True)
            self.w = self.W[:, 0]
        return new

    def _keep_range(self, pred, resampled, velocity, moved, T_cam_base) -> np.ndarray:
        """``keep_range_share``: wrists of ``pred`` put back at their ancestor's (``resampled``,
        moved by ``velocity`` with ``keep_range_target: motion``) camera distance, on their ray
        (:func:`~humimic.perception.trackers.kpf.depth.keep_wrist_range`), gated."""
        c = self.cfg
        target = resampled if c.keep_range_target == "ancestor" else self.limits.clamp(
            resampled + velocity)
        rows = {"random": ~moved, "motion": moved, "both": np.ones(len(pred), bool)}[
            c.keep_range_groups]
        gates = keep_range_gates(self.body, c, pred, T_cam_base)
        straight = None if c.keep_range_straight_deg is None else np.radians(
            c.keep_range_straight_deg)
        return kept_ranges(self.body, pred, target, rows, c.keep_range_share, T_cam_base,
                           c.keep_range_clip, self.rng, gates, straight)

    def _depth_moves(self, pred: np.ndarray, T_cam_base: np.ndarray, share: float
                     ) -> np.ndarray:
        """A ``share`` of the particles per arm get their wrist moved along its camera ray by
        a uniform range change of half-width ``depth_extent_m``."""
        cfg, rng = self.cfg, self.rng
        for side in ("R", "L"):
            pick = np.flatnonzero(rng.random(len(pred)) < share)
            delta = rng.uniform(-1.0, 1.0, len(pick)) * cfg.depth_extent_m
            pred[pick] = wrist_depth_move(self.body, pred[pick], side, delta, T_cam_base)
        return pred

    def _hand_moves(self, pred: np.ndarray, maps: CueMaps | FrameCues, T_cam_base: np.ndarray,
                    share: float) -> np.ndarray:
        """A ``share`` of the particles per arm get their hand moved onto the nearest skin
        blob (:func:`~humimic.perception.trackers.kpf.hands.hand_blob_moves`)."""
        cfg, rng = self.cfg, self.rng
        picks = {s: np.flatnonzero(rng.random(len(pred)) < share) for s in SIDES}
        both = np.concatenate(list(picks.values()))
        if len(both) == 0:
            return pred
        pose = self.body.forward(pred[both])
        T = np.asarray(T_cam_base, float)
        hands = np.concatenate([part_centres(self.body, pose, f"{SIDES[s][0]}_hand")
                                for s in SIDES])
        uv = self.lik.intr.project(hands @ T[:3, :3].T + T[:3, 3])
        uv = uv[np.all(np.isfinite(uv), axis=1)]
        if len(uv) == 0:
            return pred
        r = cfg.hand_radius_px
        if isinstance(maps, FrameCues):
            maps = maps.covering(uv.min(axis=0) - r, uv.max(axis=0) + r)
        blobs = skin_blobs(maps.skin, 1, cfg.hand_min_area_px, (0.0, np.inf))
        centres = blobs.centers + np.asarray(maps.origin, float)
        for side, pick in picks.items():
            pred[pick] = hand_blob_moves(self.body, pred[pick], side, centres, blobs.areas,
                                         self.lik.intr, T, r, rng)
        return pred

    def _condensation(self, maps, T_cam_base):
        n = len(self.particles)
        step = condensation_step(self.particles, uniform_log_weights(n) if self.w is None
                                 else np.log(np.maximum(self.w, 1e-300)),
                                 ClampedWalk(self.D, self.limits),
                                 self._log_lik(maps, T_cam_base), self.rng)
        # the weighted set before resampling is gone: keep the resampled, equally weighted one
        self.particles, self.w = step.particles, np.full(n, 1.0 / n)
        self.W = np.repeat(self.w[:, None], max(len(self.groups), 3), axis=1)
        return self.limits.clamp(step.mean)
