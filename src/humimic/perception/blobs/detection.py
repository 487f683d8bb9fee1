"""Automatic detection, loss detection and recovery of colour blobs (Ude & Atkeson eqs. 8-9).

Random blob hypotheses (centre, covariance with axes within ``[sigma_min, sigma_max]``) are
scored by the sum of colour probabilities over a fixed-size window warped onto the hypothesis
(eq. 8). Phase one samples these sums for ``period`` seconds and sets the threshold
``r_l = (1 - lambda) E f + lambda max f`` (eq. 9). Phase two keeps drawing hypotheses until one
passes ``r_l``, then hands it to the EM tracker. A tracked blob whose fill ratio (assigned pixels
over its ellipse area) stays below ``min_fill``, or whose support vanishes or that leaves the
image, or that merges with another blob, is lost; detection restarts from phase one or two.

Deviations, all switchable: hypothesis centres are drawn by default from a mixture of the
paper's uniform distribution and the colour probability on a coarse grid (``proposal='color'``,
importance sampling: uniform search alone finds a 10-pixel hand in a 320x240 image in seconds,
not the 0.5 s we need), and those colour-drawn hypotheses take the shape of the colour blob
around them (``fit_shapes``), refined by one full-resolution moment step that, like their eq. 8
sum, sees only their own blob of the colour map (``refine_fit``); ``E f`` is averaged over the
uniform draws only (the paper's random hypotheses), ``max f`` over all; eq. 8 sums
``p / (p + 1)`` by default (``score``); a hypothesis must also have at least
``min_inlier_fraction`` of its window more likely target-coloured than uniform, so a target
absent during phase one (threshold learnt from background only) does not make clutter pass;
hypotheses are not drawn on tracked blobs (``gate_mahalanobis``), a new blob settles for
``settle_frames`` before another target of its colour may be acquired, and two blobs on one
object (``merge_mahalanobis``) lose the weaker. Several targets of one colour (head and hands:
skin) form a group that searches for one missing member per frame with one threshold; they are
found one by one and which blob is which target is not decided here (the first missing member
is named; :mod:`humimic.perception.blobs.identity` names them).

All randomness comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from humimic.perception.blobs.em_blobs import BlobTracker, EMParams
from humimic.perception.blobs.hypotheses import (  # noqa: F401  (re-exported)
    _grid_points,
    blob_gate,
    coarse_blobs,
    color_sums,
    detection_threshold,
    fitted_hypotheses,
    own_blob,
    propose_centres,
    random_hypotheses,
    refine_hypotheses,
    window_points,
)
from humimic.perception.cues.color_models import ColorLUT


class TargetState(enum.Enum):
    SEARCHING = "searching"
    """Not found yet (phase one or two)."""
    TRACKING = "tracking"
    LOST = "lost"
    """Was tracked, lost, searching again."""


@dataclass(frozen=True)
class DetectionParams:
    period: float = 5.0
    lam: float = 0.67
    hypotheses: int = 16
    """Hypotheses per target per frame."""
    sigma_min_px: float = 3.0
    sigma_max_px: float = 30.0
    window_side: int = 16
    """Samples per side of the fixed-size window warped onto each hypothesis."""
    window_k_sigma: float = 1.5
    """The window spans +- this many standard deviations along the hypothesis' axes."""
    proposal: str = "color"
    """'uniform' (the paper) or 'color' (half uniform, half from a coarse colour map)."""
    score: str = "posterior"
    """What eq. 8 sums per window pixel: 'density' (the colour density p, as written; it spans
    orders of magnitude between a colour model's mode and its shaded variants, so one target's
    best window sets a threshold its same-coloured, differently lit siblings never reach) or
    'posterior' (p / (p + 1), the probability of target colour against the uniform outlier)."""
    fit_shapes: bool = True
    """With the 'color' proposal, the colour-drawn hypotheses take the shape of the colour
    map's blob around their centre (local weighted moments) instead of a random one, so a
    target that appears is usually found in its first frame (the uniform half stays random)."""
    fit_radius_cells: int = 6
    """Half-size (coarse cells) of the neighbourhood the shape is fitted on."""
    fit_sigma_min_px: float = 1.0
    """Smallest axis of a fitted hypothesis (px). A fitted shape is measured, not guessed: it
    may be smaller than ``sigma_min_px`` (the random hypotheses' prior), so a target smaller
    than the prior (a hand ~9 px across at 2 m: sigma ~2.2 px) is hypothesised at its own size
    instead of in a window it cannot fill. 1 px: the EM tracker's own floor (``min_var_px2``);
    at 2 px the hand hanging 1.2 m away (8 px, thinner across) is never found."""
    refine_fit: bool = True
    """Colour-fitted hypotheses take one full-resolution moment step before they are scored
    (:func:`~humimic.perception.blobs.hypotheses.refine_hypotheses`: the shape widened by
    one grid cell, the window by one more sigma): a coarse fit of a blob narrower than a cell
    sits on the cell's centre and its thin window slides off the blob. The step and the
    eq. 8 sums of these hypotheses see only their own blob of the coarse colour map
    (:func:`~humimic.perception.blobs.hypotheses.blob_gate`): ungated, the widened window
    took in the head or hand beside it and the hypotheses drifted and merged. See
    ``perception.detection.refine_fit`` for what was measured."""
    proposal_grid_px: int = 4
    """Smallest spacing (px) of the coarse colour map the 'color' proposal draws from."""
    proposal_cells: int = 80
    """The coarse map has at most this many cells across the image (its spacing grows with the
    image width, so its cost does not)."""
    restart_phase: int = 2
    """After a loss, restart detection from phase 1 or 2."""
    min_inlier_fraction: float = 0.1
    min_fill: float = 0.3
    lost_frames: int = 3
    """Consecutive frames of fill below min_fill before a target is declared lost."""
    min_support_px: float = 4.0
    merge_mahalanobis: float = 1.0
    """Two tracked blobs whose centres are closer than this in the metric of the sum of their
    covariances have merged (two targets on one object): the less supported one is lost."""
    settle_frames: int = 3
    """After an acquisition, no other target of the same colour model is acquired until the new
    blob has been tracked this many frames (so that its gate covers the whole object)."""
    gate_mahalanobis: float = 2.5
    """Hypotheses centred this close to a tracked blob are not drawn."""
    backoff_s: float = 2.0
    backoff_every: int = 3
    """A group whose phase-two search has found nothing for ``backoff_s`` searches only every
    ``backoff_every`` frames (a target that is not there costs a third), until it finds one or
    loses another target. Occlusions shorter than ``backoff_s`` are searched at full rate."""


@dataclass
class _Group:
    """Targets sharing one colour model: one search and one threshold (eq. 9) for all."""

    lut: ColorLUT
    members: list[int]
    phase: int = 1
    t_phase_start: float | None = None
    f_sum: float = 0.0
    f_count: int = 0
    f_max: float = 0.0
    threshold: float | None = None
    t_fail_since: float | None = None
    """Since when phase two has searched without finding anything (for the back-off)."""
    frame: int = 0

    def restart_phase_one(self) -> None:
        self.phase, self.t_phase_start = 1, None
        self.f_sum, self.f_count, self.f_max = 0.0, 0, 0.0


@dataclass
class _Target:
    name: str
    group: int
    state: TargetState = TargetState.SEARCHING
    low_fill_frames: int = 0
    acquisitions: int = 0


@dataclass(frozen=True)
class TargetReport:
    name: str
    state: TargetState
    phase: int
    """Detection phase (1 sampling, 2 searching) while not tracking; 0 while tracking."""
    centre: np.ndarray
    cov: np.ndarray
    fill: float
    threshold: float | None


class DetectingTracker:
    """Detection (eqs. 8-9) + EM tracking (eqs. 1-7) of named targets in one image stream.

    Targets given the same :class:`ColorLUT` object form a colour group: per frame the group
    searches for one of its missing members (they are interchangeable until named by the
    caller), and phase one learns one threshold for the group.
    """

    def __init__(self, names: list[str], luts: list[ColorLUT], rng: np.random.Generator,
                 params: DetectionParams | None = None,
                 em_params: EMParams | None = None) -> None:
        params = params or DetectionParams()
        if len(names) != len(luts):
            raise ValueError("one colour LUT per target name")
        if params.restart_phase not in (1, 2):
            raise ValueError("restart_phase must be 1 or 2")
        if params.proposal not in ("uniform", "color"):
            raise ValueError("proposal must be 'uniform' or 'color'")
        if params.score not in ("density", "posterior"):
            raise ValueError("score must be 'density' or 'posterior'")
        self.rng = rng
        self.params = params
        self.tracker = BlobTracker(luts, em_params or EMParams())
        self.groups: list[_Group] = []
        self.targets: list[_Target] = []
        for k, (name, lut) in enumerate(zip(names, luts, strict=True)):
            g = next((i for i, gr in enumerate(self.groups) if gr.lut is lut), None)
            if g is None:
                g = len(self.groups)
                self.groups.append(_Group(lut, []))
            self.groups[g].members.append(k)
            self.targets.append(_Target(name, g))

    def process(self, t: float, image: np.ndarray) -> list[TargetReport]:
        """Track, check for losses, then search for the targets not tracked. Returns reports."""
        frame = self.tracker.update(image)
        self._check_losses(frame, image.shape[:2])
        if any(tg.state != TargetState.TRACKING for tg in self.targets):
            self._search(t, image)
        return self.reports(frame.fill)

    def reports(self, fill: np.ndarray | None = None) -> list[TargetReport]:
        tr = self.tracker
        out = []
        for k, tg in enumerate(self.targets):
            on = tg.state == TargetState.TRACKING
            g = self.groups[tg.group]
            out.append(TargetReport(tg.name, tg.state, 0 if on else g.phase,
                                    tr.centres[k].copy(), tr.covs[k].copy(),
                                    float(fill[k]) if (fill is not None and on) else 0.0,
                                    g.threshold))
        return out

    def _lose(self, k: int) -> None:
        tg = self.targets[k]
        self.tracker.stop(k)
        tg.state = TargetState.LOST
        tg.low_fill_frames = 0
        g = self.groups[tg.group]
        g.t_fail_since = None  # search every frame again
        if self.params.restart_phase == 1 or g.threshold is None:
            g.restart_phase_one()
        else:
            g.phase = 2

    def _check_losses(self, frame, image_shape) -> None:
        p, tr = self.params, self.tracker
        H, W = image_shape
        for k in np.flatnonzero(tr.active).tolist():
            tg = self.targets[k]
            x, y = tr.centres[k].tolist()
            tg.low_fill_frames = tg.low_fill_frames + 1 if frame.fill[k] < p.min_fill else 0
            if (tg.low_fill_frames >= p.lost_frames or frame.support_px[k] < p.min_support_px
                    or not (0.0 <= x <= W - 1 and 0.0 <= y <= H - 1)
                    or not np.all(np.isfinite(tr.covs[k]))):
                self._lose(k)
        act = np.flatnonzero(tr.active).tolist()
        for i in act:  # merged blobs (same colour, same object): keep the better supported
            for j in act:
                if i < j and tr.active[i] and tr.active[j] and self._merged(i, j):
                    self._lose(j if frame.support_px[j] <= frame.support_px[i] else i)

    def _merged(self, i: int, j: int) -> bool:
        tr = self.tracker
        d = tr.centres[i] - tr.centres[j]
        return bool(d @ np.linalg.solve(tr.covs[i] + tr.covs[j], d)
                    < self.params.merge_mahalanobis ** 2)

    def _gate(self, centres: np.ndarray) -> np.ndarray:
        """Mask of hypothesis centres (or grid points) away from every tracked blob."""
        keep = np.ones(len(centres), bool)
        tr, g2 = self.tracker, self.params.gate_mahalanobis ** 2
        for k in np.flatnonzero(tr.active).tolist():
            (a, b), (_, c) = tr.covs[k].tolist()
            det = a * c - b * b
            du, dv = centres[:, 0] - tr.centres[k, 0], centres[:, 1] - tr.centres[k, 1]
            keep &= (c * du * du - 2.0 * b * du * dv + a * dv * dv) > g2 * det
        return keep

    def _search(self, t: float, image: np.ndarray) -> None:
        p, tr = self.params, self.tracker
        H, W = image.shape[:2]
        settling = {self.targets[k].group for k in np.flatnonzero(tr.active).tolist()
                    if tr.age[k] < p.settle_frames}
        for gi, g in enumerate(self.groups):
            missing = [k for k in g.members if self.targets[k].state != TargetState.TRACKING]
            if not missing or (g.phase == 2 and gi in settling):
                continue
            g.frame += 1
            if (g.phase == 2 and g.t_fail_since is not None and t - g.t_fail_since > p.backoff_s
                    and g.frame % max(p.backoff_every, 1)):
                continue
            if g.t_phase_start is None:
                g.t_phase_start = t
            lik = None
            step = max(p.proposal_grid_px, -(-W // p.proposal_cells))
            if p.proposal == "color":
                lik = g.lut.lookup(image[step // 2::step, step // 2::step]).astype(np.float64)
                near = ~self._gate(_grid_points(H, W, step)).reshape(lik.shape)
                tracked = near & (lik >= 1.0)  # cells of tracked blobs (posterior >= 1/2)
                lik[near] = 0.0
            centres, uniform = propose_centres(self.rng, p.hypotheses, (H, W), lik, step)
            keep = self._gate(centres)
            centres, uniform = centres[keep], uniform[keep]
            covs = random_hypotheses(self.rng, centres, p.sigma_min_px, p.sigma_max_px)
            gate = None
            if p.fit_shapes and lik is not None and (~uniform).any():
                fit = ~uniform  # colour-drawn centres: hypotheses shaped like the blob there
                post = lik / (lik + 1.0)
                labels = coarse_blobs(post)
                own = np.where(fit, own_blob(labels, centres, step), -1)  # before the fit
                centres[fit], covs[fit] = fitted_hypotheses(
                    post, centres[fit], step, p.fit_radius_cells,
                    min(p.fit_sigma_min_px, p.sigma_min_px), p.sigma_max_px, labels)
                if p.refine_fit:  # each refined hypothesis sees its own colour blob only
                    labels[tracked] = labels.max() + 1  # tracked blobs: another blob
                    gate = blob_gate(labels, own, step)
                    centres[fit], covs[fit] = refine_hypotheses(
                        image, g.lut, centres[fit], covs[fit], p.window_side,
                        p.window_k_sigma + 1.0, float(step),
                        min(p.fit_sigma_min_px, p.sigma_min_px), p.sigma_max_px,
                        blob_gate(labels, own[fit], step))
            f, inlier = color_sums(image, g.lut, centres, covs, p.window_side, p.window_k_sigma,
                                   p.score, gate)
            if g.phase == 1:  # Ude phase one: sample E f (random hypotheses) and max f
                g.f_sum += float(f[uniform].sum())
                g.f_count += int(uniform.sum())
                g.f_max = max(g.f_max, float(f.max(initial=0.0)))
                if t - g.t_phase_start >= p.period:
                    g.threshold = detection_threshold(g.f_sum / max(g.f_count, 1), g.f_max,
                                                      p.lam)
                    g.phase = 2
                continue
            ok = (f > g.threshold) & (inlier >= p.min_inlier_fraction)  # Ude eq. 8
            if not ok.any():
                g.t_fail_since = t if g.t_fail_since is None else g.t_fail_since
            else:
                g.t_fail_since = None
                k = missing[0]
                best = int(np.argmax(np.where(ok, f, -np.inf)))
                tr.start(k, centres[best], covs[best])
                tg = self.targets[k]
                tg.state = TargetState.TRACKING
                tg.low_fill_frames = 0
                tg.acquisitions += 1
