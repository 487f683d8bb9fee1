"""The ICU tracker and its state machine (Menezes sec. 5.2.2, Fig. 15).

Machine states (:data:`MACHINE`): ``init`` -- nobody seen yet: the face detector (and, with
``recognition``, the recogniser) runs on every whole frame; ``tracking`` -- a face recognised
as the tutor (or any face without recognition) started ICONDENSATION on (u, v, s): particles
come from the dynamics, from the prior and from the detected faces weighted by their
probability of being the tutor (eq. 12), the face detector running every ``detect_every``
frames in a window around the estimate; ``lost`` -- for ``lost_frames`` frames the colour at
the estimate stayed unlike the references (head's or torso's Bhattacharyya distance above
``lost_colour``) or the face there was recognised as someone else, or the estimate left the
image: back to whole-frame detection, and to ``tracking`` when the
tutor's face is found again. (The paper's machine also switches between image-based and 3-D
tracking modules by distance; only the image-based module exists here.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.estimation.particles import Gaussian, ParticleFilter, RandomWalk, UniformBox
from humimic.perception.cues.edges import edge_maps, grey
from humimic.perception.cues.histograms import quantize, update_reference
from humimic.perception.cues.importance import recognition_proposal
from humimic.perception.cues.templates import head_and_shoulders
from humimic.perception.faces.detect import box_centers, crop_faces
from humimic.perception.trackers.icu.likelihood import colour_distance, log_likelihood, references

MACHINE = ("init", "tracking", "lost")
FACE_TO_HEAD = 1.0
"""Head width (the state's s) per Haar face-box width."""
WINDOW_HALF = 1.2
"""While tracking, faces are searched within this many head widths of the estimate..."""
WINDOW_SIZES = (0.7, 1.45)
"""... and only at sizes between these multiples of the estimated face width."""


@dataclass(frozen=True)
class IcuStep:
    state: str
    mean: np.ndarray
    """(3,) (u, v, s); NaN while searching."""
    spread_px: float
    particles: np.ndarray | None
    weights: np.ndarray | None
    faces: np.ndarray
    """(K, 4) face boxes detected this frame (x, y, w, h)."""
    confidence: float
    """Probability that the best face is the tutor (NaN without recognition or face)."""
    probabilities: np.ndarray
    """(K,) each face's probability of being the tutor (1 without recognition)."""
    colour: float
    """Mean Bhattacharyya distance at the estimate (NaN while searching)."""


class IcuTracker:
    """``step(image)`` per frame. ``detector``: a FaceDetector; ``recogniser``: an
    EigenfaceModel and the tutor's class index (or None: any face is the tutor)."""

    def __init__(self, cfg, width: int, height: int, rng: np.random.Generator, detector,
                 recogniser=None, tutor: int = 0):
        self.cfg, self.rng, self.detector = cfg, rng, detector
        self.recogniser, self.tutor = recogniser, tutor
        self.width, self.height = width, height
        self.template = head_and_shoulders(cfg.n_points)
        self.sigma = np.asarray(cfg.dynamics, float)
        self.prior = UniformBox([0.0, 0.0, 0.8 * cfg.min_face_px],
                                [width, height, max(height, cfg.min_face_px + 1.0)])
        self.pf = ParticleFilter("icondensation", RandomWalk(self.sigma), self.prior,
                                 cfg.n_particles, cfg.alpha, cfg.beta)
        self.kappa = np.asarray(cfg.kappa, float)
        self.state = "init"
        self.bad = 0
        self.frame = 0
        self.refs: np.ndarray | None = None

    # ---- detection and recognition -----------------------------------------------------------
    def faces(self, g: np.ndarray, window=None, sizes=None) -> tuple[np.ndarray, np.ndarray]:
        """Face boxes ``(K, 4)`` in the whole image (searching ``window`` (x0, y0, x1, y1)
        only, and face ``sizes`` (min, max) px only, if given) and each face's probability of
        being the tutor ``(K,)``."""
        x0, y0, x1, y1 = window or (0, 0, self.width, self.height)
        boxes = self.detector.detect(np.ascontiguousarray(g[y0:y1, x0:x1]), sizes)
        boxes = boxes + np.array([x0, y0, 0.0, 0.0])
        if self.recogniser is None or not len(boxes):
            return boxes, np.ones(len(boxes))
        p = self.recogniser.probabilities(crop_faces(g, boxes))[:, self.tutor]
        return boxes, p

    def _window(self, mean: np.ndarray) -> tuple[int, int, int, int]:
        u, v, s = mean
        h = WINDOW_HALF * s
        x0, y0 = int(max(0, u - h)), int(max(0, v - h))
        x1, y1 = int(min(self.width, u + h)), int(min(self.height, v + h))
        return x0, y0, max(x1, x0 + 1), max(y1, y0 + 1)

    @staticmethod
    def face_states(boxes: np.ndarray) -> np.ndarray:
        return np.column_stack([box_centers(boxes), boxes[:, 2] * FACE_TO_HEAD])

    # ---- per frame ---------------------------------------------------------------------------
    def step(self, image: np.ndarray) -> IcuStep:
        self.frame += 1
        g = grey(image)
        q = quantize(image, self.cfg.bins)
        if self.state != "tracking":
            return self._search(image, g, q)
        return self._track(g, q)

    def _search(self, image, g, q) -> IcuStep:
        boxes, p = self.faces(g)
        ok = p >= self.cfg.min_confidence
        conf = float(p.max()) if len(p) and self.recogniser is not None else np.nan
        nan = np.full(3, np.nan)
        if not ok.any():
            return IcuStep(self.state, nan, np.nan, None, None, boxes, conf, p, np.nan)
        best = self.face_states(boxes)[int(np.argmax(np.where(ok, p, -1.0)))]
        self.pf.initialize(self.rng, Gaussian(best, np.diag(self.sigma**2)))
        self.refs = references(q, best)
        self.state, self.bad = "tracking", 0
        return IcuStep("tracking", best, 0.0, self.pf.particles.copy(),
                       np.exp(self.pf.log_weights), boxes, conf, p, 0.0)

    def _someone_else(self, boxes: np.ndarray, p: np.ndarray, mean: np.ndarray) -> bool:
        """A face on the estimate (centre within half a head width) that the recogniser
        does not take for the tutor (Fig. 15: recognition status)."""
        if self.recogniser is None or not len(boxes):
            return False
        near = np.hypot(*(box_centers(boxes) - mean[:2]).T) < 0.5 * mean[2]
        return bool(near.any() and np.all(p[near] < self.cfg.min_confidence))

    def _track(self, g, q) -> IcuStep:
        cfg = self.cfg
        boxes, p = np.zeros((0, 4)), np.zeros(0)
        importance = None
        if self.frame % cfg.detect_every == 0:
            m = self.pf.mean
            boxes, p = self.faces(g, self._window(m), (WINDOW_SIZES[0] * m[2] / FACE_TO_HEAD,
                                                       WINDOW_SIZES[1] * m[2] / FACE_TO_HEAD))
            if len(boxes):  # Menezes eq. 12
                importance = recognition_proposal(
                    box_centers(boxes), p, self.sigma[:2], boxes[:, 2] * FACE_TO_HEAD,
                    self.sigma[2])
        dt = edge_maps(g).dt if "shape" in cfg.cues else None
        step = self.pf.step(
            lambda x: log_likelihood(dt, q, x, self.template, self.refs, cfg.sigma_s,
                                     cfg.sigma_c, cfg.cues), self.rng, importance=importance)
        mean = step.mean
        colour = colour_distance(q, mean, self.refs)
        inside = 0 <= mean[0] < self.width and 0 <= mean[1] < self.height
        good = (step.ok and inside and colour <= cfg.lost_colour
                and not self._someone_else(boxes, p, mean))
        self.bad = 0 if good else self.bad + 1
        if good:  # Menezes eq. 13, per patch
            self.refs = update_reference(self.refs, references(q, mean), self.kappa)
        if self.bad >= cfg.lost_frames or not inside:
            self.state = "lost"
        cov = self.pf.cov
        conf = float(p.max()) if len(p) and self.recogniser is not None else np.nan
        return IcuStep(self.state, mean, float(np.sqrt(cov[0, 0] + cov[1, 1])),
                       self.pf.particles, np.exp(self.pf.log_weights), boxes, conf, p, colour)
