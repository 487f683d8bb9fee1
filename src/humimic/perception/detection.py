"""Automatic detection, loss detection and recovery of colour blobs (Ude & Atkeson eqs. 8-9).

Random blob hypotheses (centre, covariance with axes within ``[sigma_min, sigma_max]``) are
scored by the sum of colour probabilities over a fixed-size window warped onto the hypothesis
(eq. 8). Phase one samples these sums for ``phase_one_s`` seconds and sets the threshold
``r_l = (1 - lambda) E f + lambda max f`` (eq. 9). Phase two keeps drawing hypotheses until one
passes ``r_l``, then hands it to the EM tracker. A tracked blob whose fill ratio (assigned pixels
over its ellipse area) stays below ``min_fill``, or whose support vanishes or that leaves the
image, or that merges with another blob, is lost; detection restarts from phase one or two.

Deviations, all switchable: hypothesis centres are drawn by default from a mixture of the
paper's uniform distribution and the colour probability on a coarse grid (``proposal='color'``,
importance sampling: uniform search alone finds a 10-pixel hand in a 320x240 image in seconds,
not the 0.5 s we need); ``E f`` is averaged over the uniform draws only (the paper's random
hypotheses), ``max f`` over all; a hypothesis must also have at least ``min_inlier_fraction``
of its window more likely target-coloured than uniform, so a target absent during phase one
(threshold learnt from background only) does not make clutter pass; hypotheses are not drawn
on tracked blobs (``gate_mahalanobis``), a new blob settles for ``settle_frames`` before another
target of its colour may be acquired, and two blobs on one object (``merge_mahalanobis``) lose
the weaker. Several targets of one colour (head and hands: skin) are thus found one by one;
which blob is which target is not decided here (first found, first named).

All randomness comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from humimic.perception.color_models import ColorLUT
from humimic.perception.em_blobs import BlobTracker, EMParams


class TargetState(enum.Enum):
    SEARCHING = "searching"
    """Not found yet (phase one or two)."""
    TRACKING = "tracking"
    LOST = "lost"
    """Was tracked, lost, searching again."""


@dataclass(frozen=True)
class DetectionParams:
    phase_one_s: float = 5.0
    lam: float = 0.67
    n_hypotheses: int = 16
    """Hypotheses per target per frame."""
    sigma_min_px: float = 3.0
    sigma_max_px: float = 30.0
    window_side: int = 16
    """Samples per side of the fixed-size window warped onto each hypothesis."""
    window_k_sigma: float = 1.5
    """The window spans +- this many standard deviations along the hypothesis' axes."""
    proposal: str = "color"
    """'uniform' (the paper) or 'color' (half uniform, half from a coarse colour map)."""
    proposal_grid_px: int = 4
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


def random_hypotheses(rng: np.random.Generator, centres: np.ndarray, sigma_min: float,
                      sigma_max: float) -> np.ndarray:
    """Covariances ``(n, 2, 2)`` for hypothesis ``centres (n, 2)``: axes log-uniform in
    ``[sigma_min, sigma_max]``, orientation uniform."""
    n = len(centres)
    sig = np.exp(rng.uniform(math.log(sigma_min), math.log(sigma_max), size=(n, 2)))
    th = rng.uniform(0.0, math.pi, size=n)
    c, s = np.cos(th), np.sin(th)
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    return (R * (sig**2)[:, None, :]) @ np.swapaxes(R, 1, 2)


def window_points(centres: np.ndarray, covs: np.ndarray, side: int, k_sigma: float
                  ) -> np.ndarray:
    """Fixed ``side x side`` grid over ``[-k, k]^2`` warped by each hypothesis: ``(n, side^2, 2)``.

    ``u = x_l + L_l g`` with ``L_l L_l^T = Sigma_l`` (the paper's affine ROI warping).
    """
    g1 = np.linspace(-k_sigma, k_sigma, side)
    g = np.stack(np.meshgrid(g1, g1, indexing="xy"), -1).reshape(-1, 2)
    L = np.linalg.cholesky(covs)
    return centres[:, None, :] + g[None] @ np.swapaxes(L, 1, 2)


def color_sums(image: np.ndarray, lut: ColorLUT, centres: np.ndarray, covs: np.ndarray,
               side: int, k_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """``f(Theta_l) = sum_u p(I_u | Theta_l)`` over each warped window (nearest pixel; points off
    the image count 0), and the fraction of window points with ``p > 1`` (uniform).  # Ude eq. 8
    """
    H, W = image.shape[:2]
    pts = np.rint(window_points(centres, covs, side, k_sigma)).astype(np.intp)
    inside = (pts[..., 0] >= 0) & (pts[..., 0] < W) & (pts[..., 1] >= 0) & (pts[..., 1] < H)
    u = np.clip(pts[..., 0], 0, W - 1)
    v = np.clip(pts[..., 1], 0, H - 1)
    p = lut.lookup(image[v, u]) * inside
    return p.sum(axis=1, dtype=np.float64), (p > 1.0).mean(axis=1)


def detection_threshold(mean_f: float, max_f: float, lam: float) -> float:
    """``r_l = (1 - lambda) E f + lambda max f``.  # Ude eq. 9"""
    return (1.0 - lam) * mean_f + lam * max_f


def propose_centres(rng: np.random.Generator, n: int, image_shape: tuple[int, int],
                    coarse_lik: np.ndarray | None, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` centres (px): uniform, or half uniform and half from ``coarse_lik`` (a colour
    probability map sampled every ``grid`` px), jittered within the grid cell. Also returns
    which centres are uniform draws (the paper's random hypotheses)."""
    H, W = image_shape
    out = rng.uniform((0.0, 0.0), (W - 1.0, H - 1.0), size=(n, 2))
    uniform = np.ones(n, bool)
    if coarse_lik is None or n < 2:
        return out, uniform
    c = np.cumsum(coarse_lik.ravel(), dtype=np.float64)
    if not c[-1] > 0.0:
        return out, uniform
    m = n // 2
    uniform[:m] = False
    idx = np.minimum(np.searchsorted(c, rng.uniform(0.0, c[-1], size=m), side="right"),
                     c.size - 1)
    iy, ix = np.divmod(idx, coarse_lik.shape[1])
    jitter = rng.uniform(-0.5 * grid, 0.5 * grid, size=(m, 2))
    out[:m] = np.clip(np.stack([ix, iy], -1) * grid + jitter, 0.0, (W - 1.0, H - 1.0))
    return out, uniform


@dataclass
class _Target:
    name: str
    state: TargetState = TargetState.SEARCHING
    phase: int = 1
    t_phase_start: float | None = None
    f_sum: float = 0.0
    f_count: int = 0
    f_max: float = 0.0
    threshold: float | None = None
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
    """Detection (eqs. 8-9) + EM tracking (eqs. 1-7) of named targets in one image stream."""

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
        self.rng = rng
        self.params = params
        self.tracker = BlobTracker(luts, em_params or EMParams())
        self.targets = [_Target(n) for n in names]

    def process(self, t: float, image: np.ndarray) -> list[TargetReport]:
        """Track, check for losses, then search for the targets not tracked. Returns reports."""
        frame = self.tracker.update(image)
        self._check_losses(frame, image.shape[:2])
        searching = [k for k, tg in enumerate(self.targets) if tg.state != TargetState.TRACKING]
        if searching:
            self._search(t, image, searching)
        return self.reports(frame.fill)

    def reports(self, fill: np.ndarray | None = None) -> list[TargetReport]:
        tr = self.tracker
        out = []
        for k, tg in enumerate(self.targets):
            on = tg.state == TargetState.TRACKING
            out.append(TargetReport(tg.name, tg.state, 0 if on else tg.phase,
                                    tr.centres[k].copy(), tr.covs[k].copy(),
                                    float(fill[k]) if (fill is not None and on) else 0.0,
                                    tg.threshold))
        return out

    def _lose(self, k: int) -> None:
        tg = self.targets[k]
        self.tracker.stop(k)
        tg.state = TargetState.LOST
        tg.low_fill_frames = 0
        if self.params.restart_phase == 1 or tg.threshold is None:
            tg.phase, tg.t_phase_start = 1, None
            tg.f_sum, tg.f_count, tg.f_max = 0.0, 0, 0.0
        else:
            tg.phase = 2

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
            d = centres - tr.centres[k]
            keep &= np.einsum("ni,ij,nj->n", d, np.linalg.inv(tr.covs[k]), d) > g2
        return keep

    def _search(self, t: float, image: np.ndarray, searching: list[int]) -> None:
        p, tr = self.params, self.tracker
        H, W = image.shape[:2]
        coarse: dict[int, np.ndarray] = {}
        settling = {id(tr.luts[k]) for k in np.flatnonzero(tr.active).tolist()
                    if tr.age[k] < p.settle_frames}
        for k in searching:
            tg, lut = self.targets[k], tr.luts[k]
            if tg.t_phase_start is None:
                tg.t_phase_start = t
            lik = None
            if p.proposal == "color":
                if id(lut) not in coarse:
                    g = p.proposal_grid_px
                    sub = image[g // 2::g, g // 2::g]
                    lik_map = lut.lookup(sub).astype(np.float64)
                    vv, uu = np.mgrid[g // 2:H:g, g // 2:W:g]
                    pts = np.stack([uu.ravel(), vv.ravel()], -1).astype(float)
                    lik_map.ravel()[~self._gate(pts)] = 0.0
                    coarse[id(lut)] = lik_map
                lik = coarse[id(lut)]
            centres, uniform = propose_centres(self.rng, p.n_hypotheses, (H, W), lik,
                                               p.proposal_grid_px)
            keep = self._gate(centres)
            centres, uniform = centres[keep], uniform[keep]
            covs = random_hypotheses(self.rng, centres, p.sigma_min_px, p.sigma_max_px)
            f, inlier = color_sums(image, lut, centres, covs, p.window_side, p.window_k_sigma)
            if tg.phase == 1:  # Ude phase one: sample E f (random hypotheses) and max f
                tg.f_sum += float(f[uniform].sum())
                tg.f_count += int(uniform.sum())
                tg.f_max = max(tg.f_max, float(f.max(initial=0.0)))
                if t - tg.t_phase_start >= p.phase_one_s:
                    tg.threshold = detection_threshold(tg.f_sum / max(tg.f_count, 1), tg.f_max,
                                                       p.lam)
                    tg.phase = 2
                continue
            ok = (f > tg.threshold) & (inlier >= p.min_inlier_fraction)  # Ude eq. 8
            if ok.any() and id(lut) not in settling:
                settling.add(id(lut))
                best = int(np.argmax(np.where(ok, f, -np.inf)))
                tr.start(k, centres[best], covs[best])
                tg.state = TargetState.TRACKING
                tg.low_fill_frames = 0
                tg.acquisitions += 1
