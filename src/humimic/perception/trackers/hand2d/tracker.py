"""The 2-D hand tracker (Menezes sec. 5.1, Table 3): a particle filter on (u, v, s, theta)
with random-walk dynamics and the fused cues of :mod:`.likelihood`, started and restarted by
:mod:`.detect`.

States (``messages.TRACK_STATES``): ``init`` -- searching the whole image until the detectors
agree; ``tracking`` -- one filter cycle per frame, cues computed only in the particles' region
of interest; ``lost`` -- the estimate left the hand (its mean edge distance above
``lost_edge_px`` while its rim does not separate skin from background, or too little skin on
its palm) for ``lost_frames`` frames in a row: searching
again, as in ``init``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.estimation.particles import (
    Gaussian,
    GaussianMixture,
    ParticleFilter,
    RandomWalk,
    UniformBox,
)
from humimic.perception.cues.edges import grey as to_grey
from humimic.perception.cues.histograms import patch_histograms, quantize, update_reference
from humimic.perception.cues.importance import Blobs
from humimic.perception.cues.motion import OpticalFlow
from humimic.perception.cues.skin import rim_separates, rim_skin_sides
from humimic.perception.cues.templates import hand
from humimic.perception.trackers.hand2d.detect import detect_hands, face_on_blob
from humimic.perception.trackers.hand2d.likelihood import (
    PALM_PATCH,
    FrameCues,
    Params,
    frame_cues,
    log_likelihood,
    mean_edge_distance,
    roi_of,
    skin_fraction,
)

SKIN_POSTERIOR = 0.5
"""A pixel is skin when its colour is more likely under the skin model than uniform ..."""
SKIN_SMOOTH_PX = 3
"""... averaged over a box this many pixels wide (:func:`skin_mask`)."""


def skin_mask(posterior: np.ndarray, box_px: int = SKIN_SMOOTH_PX,
              threshold: float = SKIN_POSTERIOR) -> np.ndarray:
    """Skin pixels (bool) where the skin posterior's mean over a ``box_px`` box exceeds
    ``threshold``: a hand is a solid region of skin, while a surface whose colour only
    touches the skin model's (lab_clutter's dark-brown posts under a dark skin, pixel noise
    of 2 levels: 18 % of their pixels above 0.5, scattered) gives speckle that the box mean
    removes; the speckle had made hand-sized blobs the detector started on (fig5 / hand_people,
    seed 99, 3 s, skin [0.40, 0.27, 0.20], with the background cut: lost 39 / 42 %, centre
    RMSE 80 / 89 px with a 1-px box; 2.2 / 0 %, 1.7 / 1.9 px with 3 px; with both, default skin,
    hand_people seeds 99 / 5 / 7: 14 / 14 / 16 % lost, against 17 / 18 / 16 % before)."""
    p = np.asarray(posterior, np.float32)
    if box_px > 1:
        p = cv2.blur(p, (box_px, box_px), borderType=cv2.BORDER_REPLICATE)
    return p > threshold


@dataclass(frozen=True)
class HandStep:
    """What one frame gave."""

    state: str
    mean: np.ndarray
    """(4,) MMSE (u, v, s, theta); NaN while searching."""
    spread_px: float
    particles: np.ndarray | None
    weights: np.ndarray | None
    edge_px: float
    """Mean edge distance at the estimate (px)."""
    skin: float
    """Skin fraction on the estimate's palm."""
    blobs: Blobs | None
    """Skin blobs of a detection frame (None while tracking)."""
    roi: tuple[int, int, int, int] | None


class Hand2DTracker:
    """``step(image)`` per frame; ``lut`` is the skin :class:`ColorLUT`, ``faces`` a
    :class:`~humimic.perception.faces.detect.FaceDetector` (or None: no face check)."""

    def __init__(self, cfg, lut, width: int, height: int, rng: np.random.Generator,
                 faces=None):
        self.cfg, self.lut, self.faces, self.rng = cfg, lut, faces, rng
        self.width, self.height = width, height
        self.template = hand(cfg.n_points)
        self.params = Params(tuple(cfg.cues), cfg.similarity, cfg.sigma_s, cfg.rho, cfg.K,
                             cfg.search_px, cfg.sigma_c, cfg.sigma_k)
        self.dyn_sigma = np.asarray(cfg.dynamics, float)
        prior = UniformBox([0.0, 0.0, cfg.min_hand_px, -0.5],
                           [width, height, max(0.5 * width, cfg.min_hand_px + 1), 0.5])
        self.pf = ParticleFilter(cfg.filter, RandomWalk(self.dyn_sigma), prior,
                                 cfg.n_particles, cfg.alpha, cfg.beta)
        self.flow = OpticalFlow()
        self.use_flow = "motion" in cfg.cues
        self.prev_grey: np.ndarray | None = None
        self.state = "init"
        self.bad = 0
        self.reference: np.ndarray | None = None

    def start(self, state: np.ndarray, image: np.ndarray) -> None:
        """Start tracking at ``state`` (u, v, s, theta): the particles around it (the
        dynamics' spread), the palm's colour reference from ``image``."""
        self.pf.initialize(self.rng, Gaussian(state, np.diag(self.dyn_sigma**2)))
        self.reference = patch_histograms(quantize(image, self.cfg.bins), state, PALM_PATCH,
                                          grid=6)[0]
        self.state, self.bad = "tracking", 0

    # ---- per frame ---------------------------------------------------------------------------
    def step(self, image: np.ndarray) -> HandStep:
        grey = to_grey(image)
        try:
            if self.state == "tracking":
                return self._track(image, grey)
            return self._search(image, grey)
        finally:
            self.prev_grey = grey

    def _cues(self, image, grey, roi, qimage=None, need_dt=False, skin=None) -> FrameCues:
        """The cue images over ``roi``; ``skin``: the skin posterior over it if already
        computed (else computed here when the ``skin`` cue is on)."""
        x0, y0, x1, y1 = roi
        g = np.ascontiguousarray(grey[y0:y1, x0:x1])
        flow = None
        if self.use_flow and self.prev_grey is not None:
            flow = self.flow(np.ascontiguousarray(self.prev_grey[y0:y1, x0:x1]), g)
        if skin is None and "skin" in self.cfg.cues:
            skin = self.lut.posterior(image[y0:y1, x0:x1]).astype(np.float32)
        edged = (g if self.cfg.edges == "grey" or image.ndim == 2
                 else np.ascontiguousarray(image[y0:y1, x0:x1]))
        return frame_cues(edged, flow, (x0, y0), self.params, self.cfg.min_flow_px, qimage,
                          need_dt, skin)

    def _rim(self, state: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The template of ``state`` in ROI pixels and its outward normals."""
        pts, inward = self.template.place(np.asarray(state)[None])
        return pts[0] - origin, -inward[0]

    def _skin(self, image) -> np.ndarray:
        return skin_mask(self.lut.posterior(image))

    def _search(self, image, grey) -> HandStep:
        posterior = self.lut.posterior(image)          # one pass for the detector and the cue
        cues = self._cues(image, grey, (0, 0, self.width, self.height), need_dt=True,
                          skin=posterior)
        is_face = (None if self.faces is None
                   else lambda box: face_on_blob(grey, box, self.faces))
        det = detect_hands(skin_mask(posterior), cues.maps.dt, cues.maps.moving,
                           self.template, self.cfg.min_hand_px, self.cfg.init_edge_px, is_face)
        best = det.best
        nan = np.full(4, np.nan)
        if len(det.states) > 1 and self.use_flow and self.prev_grey is None:
            # several hand-shaped blobs and no flow yet to say which one waves (the first
            # frame): wait a frame rather than take the best template fit -- a coin toss
            # (the synthetic tutor and distractor hands' fits differ by 0.1-0.3 px, and which
            # is closer depends on the edge detector)
            best = None
        if best is None:
            return HandStep(self.state, nan, np.nan, None, None, np.nan, np.nan, det.blobs,
                            None)
        self.start(best, image)
        d = mean_edge_distance(cues, best, self.template, self.params)
        return HandStep("tracking", best.copy(), 0.0, self.pf.particles.copy(),
                        np.exp(self.pf.log_weights), d,
                        skin_fraction(image, self.lut, best), det.blobs, None)

    def _importance(self, image) -> GaussianMixture | None:
        if self.cfg.filter != "icondensation":
            return None
        det = detect_hands(self._skin(image), np.zeros(image.shape[:2], np.float32),
                           np.zeros(image.shape[:2], np.uint8), self.template,
                           self.cfg.min_hand_px, np.inf)
        return GaussianMixture(det.states, self.dyn_sigma * [1.0, 1.0, 2.0, 2.0])

    def _track(self, image, grey) -> HandStep:
        cfg = self.cfg
        if cfg.filter == "icondensation":
            roi = (0, 0, self.width, self.height)
        else:
            pts, _ = self.template.place(self.pf.particles)
            reach = cfg.roi_margin_px + cfg.search_px + 3.0 * self.dyn_sigma[:2].max()
            roi = roi_of(pts, reach, self.width, self.height)
        q = quantize(image, cfg.bins) if "colour" in cfg.cues else None
        cues = self._cues(image, grey, roi, q)
        step = self.pf.step(
            lambda x: log_likelihood(cues, x, self.template, self.params, self.reference),
            self.rng, importance=self._importance(image))
        self.pf.particles[:, 2] = np.maximum(self.pf.particles[:, 2], 2.0)
        mean = step.mean
        d = mean_edge_distance(cues, mean, self.template, self.params)
        skin = skin_fraction(image, self.lut, mean)
        fits = d <= cfg.lost_edge_px or (cues.skin is not None and bool(rim_separates(
            *rim_skin_sides(cues.skin, *self._rim(mean, cues.origin)), cfg.lost_rim_odds)))
        good = step.ok and fits and skin >= cfg.min_skin
        self.bad = 0 if good else self.bad + 1
        if good and q is not None and self.reference is not None:
            seen = patch_histograms(q, mean, PALM_PATCH, grid=6)[0]
            self.reference = update_reference(self.reference, seen, cfg.kappa)  # eq. 13
        if self.bad >= cfg.lost_frames:
            self.state = "lost"
        cov = self.pf.cov
        return HandStep(self.state, mean, float(np.sqrt(cov[0, 0] + cov[1, 1])),
                        self.pf.particles, np.exp(self.pf.log_weights), d, skin, None, roi)
