"""Our extension (issue 14): a delayed decision between an arm's kinematic flip branches.

One camera cannot tell an arm from its kinematic flips (:mod:`~humimic.perception.trackers.
kpf.flips`: the poses with the same elbow and wrist images). In Table 1's angular pointing the
estimate takes the wrong branch where the branches meet (the forearm across the camera ray, at
rest) and keeps it; per frame the likelihood tells the truth from its mirror by a few
hundredths of a nat (a few tenths with ``skin_ring``), and resampling kills a weakly worse
branch within a few frames, so the weak evidence never adds up in the particles.

Here it adds up outside them. Per arm and flip kind ``k`` (:data:`~humimic.perception.trackers.
kpf.flips.FLIPS`), every frame's log-likelihood ratio of the estimate's flip against the
estimate, ``r_t = log p(y_t | flip_k(x_t)) - log p(y_t | x_t)`` (both at the same joint images:
the ratio is what the cues say about the branch alone), is accumulated by Page's CUSUM test
(Page 1954, "Continuous inspection schemes") with a forgetting factor ``lam``,
``S_t = max(0, lam S_{t-1} + r_t)`` (:func:`cusum_update`); when ``S`` passes the threshold
``h`` (:func:`branch_switches`) the arm changes branch: the estimate, the last estimate (so the
motion model's velocity stays a motion) and every particle's arm are replaced by their flip
``k`` (:func:`flip_arm`), and the arm's sums restart at 0. The CUSUM's clamp at 0 keeps
evidence for the current branch from piling up (a switch needs recent evidence, not a
lifetime's); ``lam`` < 1 forgets old frames (a flip of a moving arm is another pose each frame).

Measured evidence (Table 1, seed 0, ratios at the TRUE pose, flip minus truth, nats per frame,
wrist / elbow / both flips): angular hold with ``skin_ring`` 1.5 -0.79 / -0.13 / -0.07, without
-0.01 / -0.02 / -0.05; side hold -0.01 / 0.00 / -0.33 with or without the ring; at rest the
"both" flip -0.72 (the others coincide with the pose or leave the limits). At the ESTIMATE the
unrefined flips lose by 0.1-0.5 nats (the estimate sits on its branch's peak, its flips do not):
``branch_refine_polls`` compares refined poses. Numbers: ``KpfConfig.branch_threshold``.

Two gates on what is scored (29 Nov, ``i14-branch``; numbers in their ``KpfConfig`` fields):
``branch_min_separation_mm`` leaves out flips whose wrist lies near the estimate's
(:func:`wrist_separation`, :func:`gate_near_flips`: a near flip costs little if wrong, and its
evidence is the weakest), ``branch_max_step_mm`` a moving arm (the estimate lags the image).
``branch_clamp_flips`` (29 Nov, ``i14-fdec``) scores a flip outside the joint limits clamped
into them instead of leaving it out (the truth can lie next to such a flip while the estimate
is 300 mm off).
"""

from __future__ import annotations

import numpy as np

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.depth import SIDES
from humimic.perception.trackers.kpf.flips import FLIPS, arm_flips
from humimic.perception.trackers.kpf.fovea import decision_view
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.refine import refine_arms


def cusum_update(S: np.ndarray, r: np.ndarray, forget: float) -> np.ndarray:
    """Page's CUSUM with forgetting, ``max(0, forget S + r)`` elementwise; where ``r`` is NaN
    (the flip does not exist or leaves the joint limits) the sum restarts at 0."""
    S = np.asarray(S, float)
    r = np.asarray(r, float)
    return np.where(np.isfinite(r), np.maximum(0.0, forget * S + np.nan_to_num(r)), 0.0)


def clip_ratios(r: np.ndarray, cap: float | None) -> np.ndarray:
    """The ratios ``r`` clipped to ``[-cap, cap]`` nats (NaN kept; None: as they are): Huber's
    robust probability-ratio test (Huber 1965, "A robust version of the probability ratio
    test"), so that no single frame's outlier carries the CUSUM over its threshold
    (``branch_max_ratio``)."""
    r = np.asarray(r, float)
    return r if cap is None else np.clip(r, -cap, cap)


def branch_switches(S: np.ndarray, threshold: float) -> np.ndarray:
    """``(arms,)`` per row of ``S (arms, kinds)`` the kind to switch to (the largest sum above
    ``threshold``), -1 for none."""
    S = np.asarray(S, float)
    k = np.argmax(S, axis=1)
    return np.where(S[np.arange(len(S)), k] > threshold, k, -1)


def wrist_separation(body: bm.BodyModel, q: np.ndarray, flips: np.ndarray, side: str
                     ) -> np.ndarray:
    """``(K,)`` the distance (m) from arm ``side``'s wrist of the pose ``q (14,)`` to that of
    each of the poses ``flips (K, 14)`` (NaN rows give NaN): what taking a flip costs the
    wrist if it is the wrong branch (``branch_min_separation_mm``)."""
    prefix, _ = SIDES[side]
    flips = np.atleast_2d(np.asarray(flips, float))
    ok = np.all(np.isfinite(flips), axis=1)
    d = np.full(len(flips), np.nan)
    if ok.any():
        w = body.forward(np.vstack([np.asarray(q, float)[None], flips[ok]])).joint(
            f"{prefix}_wrist")
        d[ok] = np.linalg.norm(w[1:] - w[0], axis=1)
    return d


def gate_near_flips(r: np.ndarray, separation: np.ndarray, min_separation: float | None
                    ) -> np.ndarray:
    """The ratios ``r`` with those of flips whose wrist lies nearer than ``min_separation``
    (m; None: none) to the estimate's set to NaN (out of the CUSUM, which restarts their sums):
    a near flip costs at most its separation if taken wrongly, and the cues' evidence between
    near flips is the weakest (a small depth difference, a small perspective scale change)."""
    r = np.array(r, float)
    if min_separation is not None:
        r[~(np.asarray(separation, float) >= min_separation)] = np.nan
    return r


def flip_arm(body: bm.BodyModel, q: np.ndarray, side: str, kind: str, c_ref: np.ndarray,
             limits: bm.JointLimits, fallback: np.ndarray) -> np.ndarray:
    """States ``q (N, 14)`` with arm ``side`` replaced by its flip ``kind`` seen from ``c_ref``
    (reference frame); rows whose flip does not exist or leaves ``limits`` take ``fallback``'s
    ``(14,)`` arm."""
    _, j = SIDES[side]
    q = np.atleast_2d(np.asarray(q, float))
    new = arm_flips(body, q, side, c_ref)[kind]
    ok = np.all(np.isfinite(new), axis=1)
    ok[ok] = limits.inside(new[ok])
    out = q.copy()
    out[:, j:j + 4] = np.where(ok[:, None], new[:, j:j + 4], np.asarray(fallback)[j:j + 4])
    return out


class FlipBranches:
    """The branch decision of a :class:`~humimic.perception.trackers.kpf.tracker.KpfTracker`
    (``branch_threshold``); ``history`` per frame ``(r, S)``, each ``(arms, kinds)``."""

    def __init__(self, body: bm.BodyModel, intrinsics, cfg):
        self.body, self.cfg = body, cfg
        self.lik = None if cfg.branch_skin_ring is None else Likelihood(
            body, intrinsics, cfg.model_copy(update={"skin_ring": cfg.branch_skin_ring}))
        self.S = np.zeros((len(SIDES), len(FLIPS)))
        self.history: list[tuple[np.ndarray, np.ndarray]] = []
        self.separations: list[np.ndarray] = []
        """Per frame ``(arms, kinds)`` each flip's wrist separation (m, NaN: no flip)."""
        self.steps: list[np.ndarray] = []
        """Per frame ``(arms,)`` how far (m) each arm's estimated wrist moved since the last
        estimate."""

    def log_post(self, tracker, q: np.ndarray, maps, T_cam_base: np.ndarray) -> np.ndarray:
        """The decision's log-posterior of poses ``q``: the tracker's (the sigmas' floors), or
        with ``branch_skin_ring`` its likelihood with that ring (the tracker's colours)."""
        if self.lik is None:
            return tracker._log_post(q, maps, T_cam_base, floors=True)
        self.lik.share_references(tracker.lik.references)
        return (self.lik.evaluate(q, maps, T_cam_base, floors=True).log_lik
                + tracker._prior(q) + tracker._arm_prior(q).sum(1))

    def _refined(self, tracker, q: np.ndarray, side: str, f, T_cam_base: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        """``q`` with arm ``side`` refined (``branch_refine_polls``) and its log-posterior."""
        polls = self.cfg.branch_refine_polls
        if polls > 0:
            q, _ = refine_arms(self.body, q, f, tracker.D, T_cam_base, polls,
                               self.cfg.refine_step, 0.0, tracker.limits, (side,))
        return q, float(f(q[None])[0])

    def step(self, tracker, mode: np.ndarray, maps, T_cam_base: np.ndarray) -> np.ndarray:
        """:meth:`_step` with the tracker's foveal view on (``fovea.use: decision``:
        :func:`~humimic.perception.trackers.kpf.fovea.decision_view`)."""
        with decision_view(getattr(tracker, "lik", None)):
            return self._step(tracker, mode, maps, T_cam_base)

    def _step(self, tracker, mode: np.ndarray, maps, T_cam_base: np.ndarray) -> np.ndarray:
        """Update the sums with this frame's ratios at ``mode (14,)``; switch an arm whose sum
        passed the threshold (the tracker's particles and last estimate too); the estimate.
        With ``branch_refine_polls`` the ratios are between the refined estimate's arm and its
        refined flips (each at its branch's local peak, as the particles' modes are). With
        ``branch_min_separation_mm`` only the flips of the (unrefined) estimate whose wrist lies
        that far from its own are refined and scored; an arm without one is skipped, and with
        ``branch_max_step_mm`` an arm whose estimated wrist moved farther since the last
        estimate."""
        c_ref = np.linalg.inv(np.asarray(T_cam_base, float))[:3, 3]

        def f(q):
            return self.log_post(tracker, q, maps, T_cam_base)
        r = np.full((len(SIDES), len(FLIPS)), np.nan)
        sep = np.full_like(r, np.nan)
        mm, ms = self.cfg.branch_min_separation_mm, self.cfg.branch_max_step_mm
        moved = np.full(len(SIDES), np.nan)
        best = {}
        for a, side in enumerate(SIDES):
            raw = arm_flips(self.body, mode[None], side, c_ref)
            sep[a] = wrist_separation(self.body, mode, np.stack([raw[k][0] for k in FLIPS]), side)
            # a near flip is neither refined nor scored (its ratio stays NaN)
            far = np.isfinite(gate_near_flips(np.zeros(len(FLIPS)), sep[a],
                                              None if mm is None else mm / 1000.0))
            # a moving arm's ratios wait for it to stop (``branch_max_step_mm``)
            moved[a] = wrist_separation(self.body, tracker.mode, mode[None], side)[0]
            if not far.any() or (ms is not None and not moved[a] <= ms / 1000.0):
                continue
            base, ll0 = self._refined(tracker, mode, side, f, T_cam_base)
            flips = arm_flips(self.body, base[None], side, c_ref)
            for k, kind in enumerate(FLIPS):
                q = flips[kind][0]
                if not (far[k] and np.all(np.isfinite(q))):
                    continue
                if not tracker.limits.inside(q[None])[0]:
                    if not self.cfg.branch_clamp_flips:
                        continue
                    q = tracker.limits.clamp(q)   # ``branch_clamp_flips``
                best[side, k], ll = self._refined(tracker, q, side, f, T_cam_base)
                r[a, k] = ll - ll0
        self.separations.append(sep)
        self.steps.append(moved)
        r = clip_ratios(r, self.cfg.branch_max_ratio)
        self.S = cusum_update(self.S, r, self.cfg.branch_forget)
        self.history.append((r, self.S.copy()))
        for (side, _), k in zip(SIDES.items(), branch_switches(self.S, self.cfg.branch_threshold),
                                strict=True):
            if k < 0:
                continue
            kind = FLIPS[k]
            _, j = SIDES[side]
            mode = mode.copy()
            mode[j:j + 4] = best[side, k][j:j + 4]
            tracker.mode = flip_arm(self.body, tracker.mode, side, kind, c_ref,
                                    tracker.limits, mode)[0]
            tracker.particles = flip_arm(self.body, tracker.particles, side, kind, c_ref,
                                         tracker.limits, mode)
            tracker.pvel = tracker.pvel.copy()
            tracker.pvel[:, j:j + 4] = 0.0
            self.S[list(SIDES).index(side)] = 0.0
        return mode
