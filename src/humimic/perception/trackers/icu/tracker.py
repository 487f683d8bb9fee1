"""The ICU tracker and its state machine (Menezes sec. 5.2.2, Fig. 15).

Machine states (:data:`MACHINE`): ``init`` -- nobody seen yet: faces are searched (and, with
``recognition``, recognised) every frame around the skin blobs of head size (or, with
``search: whole`` or no skin model, in the whole frame); ``tracking`` -- a face recognised as
the tutor (or any face without recognition) started ICONDENSATION on (u, v, s): particles
come from the dynamics, from the prior and from the detected faces weighted by their
probability of being the tutor (eq. 12), the face detector running every ``detect_every``
frames in a window around the estimate, the shape cue's edges computed only around the
particle cloud (after ``redetect_after`` frames without the tutor's face on the estimate, the
detector runs over the whole frame instead, as the paper's detector sees the whole image, and
the tutor's face found there restarts the filter and the colour references: a cloud that
drifted onto clutter is not pulled back by eq. 12's draws alone, whose weights f / q vanish
far from every hypothesis);
``lost`` -- for ``lost_frames`` frames the colour at the estimate stayed
unlike the references (head's or torso's Bhattacharyya distance above ``lost_colour``) or the
face there was recognised as someone else, or the estimate left the image: back to the search,
and to ``tracking`` when the tutor's face is found again. (The paper's machine also switches
between image-based and 3-D tracking modules by distance: :mod:`.modules`.)
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from humimic.estimation.particles import Gaussian, ParticleFilter, RandomWalk, UniformBox
from humimic.perception.cues.edges import edge_maps, grey
from humimic.perception.cues.histograms import quantize, update_reference
from humimic.perception.cues.importance import recognition_proposal, skin_blobs
from humimic.perception.cues.templates import head_and_shoulders
from humimic.perception.faces.detect import box_centers, crop_faces
from humimic.perception.trackers.icu.likelihood import colour_distance, log_likelihood, references
from humimic.perception.trackers.icu.search import shape_roi, skin_windows, unique_boxes

MACHINE = ("init", "tracking", "lost")
FACE_TO_HEAD = 1.0
"""Head width (the state's s) per Haar face-box width."""
WINDOW_HALF = 1.0
"""While tracking, faces are searched within this many head widths of the estimate..."""
WINDOW_SIZES = (0.8, 1.3)
"""... and only at sizes between these multiples of the estimated face width (measured, 3
seeds of Figs. 9 and 10 with detection every frame: 1.2 widths at 0.7-1.45 x cost 25 % more
than 1.0 at 0.8-1.3 x for no better centre error)."""
ON_FACE = 0.3
"""The estimate is on a face when its centre is within this many face-box widths of the box's
centre (the rendered heads' box centres lie 0.1-0.15 widths from the true head centre; a cloud
that sat beside a detected face, 0.45-0.55 widths off, in Fig. 9 in ``lab_clutter``)."""
SKIN_POSTERIOR = 0.5
"""A pixel is skin when its colour is more likely under the skin model than uniform."""
EDGE_PAD_PX = 8.0
"""Margin of the shape cue's edge region beyond the cloud's templates (and 3 sigma of the
dynamics): an edge farther out than this is seen by no point within the region's border."""


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
    EigenfaceModel and the tutor's class index (or None: any face is the tutor); ``skin``: a
    skin :class:`~humimic.perception.cues.color_models.ColorLUT` to search faces around skin
    blobs only (None: the whole frame)."""

    def __init__(self, cfg, width: int, height: int, rng: np.random.Generator, detector,
                 recogniser=None, tutor: int = 0, skin=None):
        self.cfg, self.rng, self.detector = cfg, rng, detector
        self.recogniser, self.tutor, self.skin = recogniser, tutor, skin
        self.width, self.height = width, height
        self.template = head_and_shoulders(cfg.n_points)
        self.extent = np.stack([self.template.points.min(axis=0),
                                self.template.points.max(axis=0)])
        self.sigma = np.asarray(cfg.dynamics, float)
        self.prior = UniformBox([0.0, 0.0, 0.8 * cfg.min_face_px],
                                [width, height, max(height, cfg.min_face_px + 1.0)])
        self.pf = ParticleFilter("icondensation", RandomWalk(self.sigma), self.prior,
                                 cfg.n_particles, cfg.alpha, cfg.beta)
        self.kappa = np.asarray(cfg.kappa, float)
        self.state = "init"
        self.bad = 0
        self.frame = 0
        self.missed = 0
        """Consecutive tracking frames whose face search found no face taken for the tutor."""
        self.restarts = 0
        """Restarts on a tutor's face the whole-frame search found after the window had lost
        it (``redetect_after``): how often the cloud had drifted off the face."""
        self.refs: np.ndarray | None = None

    # ---- detection and recognition -----------------------------------------------------------
    def faces(self, g: np.ndarray, window=None, sizes=None) -> tuple[np.ndarray, np.ndarray]:
        """Face boxes ``(K, 4)`` in the whole image (searching ``window`` (x0, y0, x1, y1)
        only, and face ``sizes`` (min, max) px only, if given) and each face's probability of
        being the tutor ``(K,)``."""
        return self.recognise(g, self.detect(g, window, sizes))

    def detect(self, g: np.ndarray, window=None, sizes=None) -> np.ndarray:
        x0, y0, x1, y1 = window or (0, 0, self.width, self.height)
        boxes = self.detector.detect(np.ascontiguousarray(g[y0:y1, x0:x1]), sizes)
        return boxes + np.array([x0, y0, 0.0, 0.0])

    def search_faces(self, image: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Faces anywhere in the frame: around the head-sized skin blobs (a half-resolution
        skin mask) when there is a skin model and ``search`` is ``skin``, else the whole
        frame."""
        if self.skin is None or self.cfg.search != "skin":
            return self.faces(g)
        mask = self.skin.posterior(image[::2, ::2]) > SKIN_POSTERIOR
        blobs = skin_blobs(mask, 1, min_area_px=(0.25 * self.cfg.min_face_px) ** 2)
        boxes = [self.detect(g, w, sizes) for w, sizes in
                 skin_windows(2.0 * blobs.boxes, self.width, self.height,
                              self.cfg.min_face_px)]
        return self.recognise(g, unique_boxes(np.vstack([np.zeros((0, 4)), *boxes])))

    def recognise(self, g: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The boxes and each one's probability of being the tutor (1 without a recogniser)."""
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
        boxes, p = self.search_faces(image, g)
        ok = p >= self.cfg.min_confidence
        conf = float(p.max()) if len(p) and self.recogniser is not None else np.nan
        nan = np.full(3, np.nan)
        if not ok.any():
            return IcuStep(self.state, nan, np.nan, None, None, boxes, conf, p, np.nan)
        return self._start(q, boxes, p, ok)

    def _start(self, q, boxes: np.ndarray, p: np.ndarray, ok: np.ndarray) -> IcuStep:
        """(Re)start the filter and the colour references at the likeliest tutor's face."""
        conf = float(p.max()) if len(p) and self.recogniser is not None else np.nan
        best = self.face_states(boxes)[int(np.argmax(np.where(ok, p, -1.0)))]
        self.pf.initialize(self.rng, Gaussian(best, np.diag(self.sigma**2)))
        self.refs = references(q, best)
        self.state, self.bad, self.missed = "tracking", 0, 0
        return IcuStep("tracking", best, 0.0, self.pf.particles.copy(),
                       np.exp(self.pf.log_weights), boxes, conf, p, 0.0)

    def _someone_else(self, boxes: np.ndarray, p: np.ndarray, mean: np.ndarray) -> bool:
        """A face on the estimate (centre within half a head width) that the recogniser
        does not take for the tutor (Fig. 15: recognition status)."""
        if self.recogniser is None or not len(boxes):
            return False
        near = np.hypot(*(box_centers(boxes) - mean[:2]).T) < 0.5 * mean[2]
        return bool(near.any() and np.all(p[near] < self.cfg.min_confidence))

    def shape_maps(self, g: np.ndarray, boxes: np.ndarray
                   ) -> tuple[np.ndarray, tuple[int, int]]:
        """The distance transform of the edges (eq. 3) around the particle cloud and the
        detected faces (where this frame's particles come from, bar the prior's few draws) and
        its origin (x0, y0) in the image."""
        anchors = np.vstack([self.pf.particles, self.face_states(boxes)])
        anchors[:, 2] += 3.0 * self.sigma[2]
        x0, y0, x1, y1 = shape_roi(anchors, self.extent, self.width, self.height,
                                   3.0 * self.sigma[:2].max() + EDGE_PAD_PX)
        return edge_maps(g[y0:y1, x0:x1], mask=cv2.DIST_MASK_5).dt, (x0, y0)

    def _track(self, g, q) -> IcuStep:
        cfg = self.cfg
        boxes, p = np.zeros((0, 4)), np.zeros(0)
        importance = None
        if self.frame % cfg.detect_every == 0:
            m = self.pf.mean
            if 0 < cfg.redetect_after <= self.missed:  # the window lost the face: whole frame
                boxes, p = self.faces(g)
                if np.any(p >= cfg.min_confidence):  # the tutor found again: start there
                    self.restarts += 1
                    return self._start(q, boxes, p, p >= cfg.min_confidence)
            else:
                boxes, p = self.faces(g, self._window(m),
                                      (WINDOW_SIZES[0] * m[2] / FACE_TO_HEAD,
                                       WINDOW_SIZES[1] * m[2] / FACE_TO_HEAD))
            on = np.hypot(*(box_centers(boxes) - m[:2]).T) < ON_FACE * boxes[:, 2]
            self.missed = 0 if np.any(on & (p >= cfg.min_confidence)) else self.missed + 1
            if len(boxes):  # Menezes eq. 12
                importance = recognition_proposal(
                    box_centers(boxes), p, self.sigma[:2], boxes[:, 2] * FACE_TO_HEAD,
                    self.sigma[2])
        dt, origin = None, (0, 0)
        if "shape" in cfg.cues:
            dt, origin = self.shape_maps(g, boxes)
        step = self.pf.step(
            lambda x: log_likelihood(dt, q, x, self.template, self.refs, cfg.sigma_s,
                                     cfg.sigma_c, cfg.cues, origin), self.rng,
            importance=importance)
        mean = step.mean
        seen = references(q, mean)
        colour = colour_distance(q, mean, self.refs, seen)
        inside = 0 <= mean[0] < self.width and 0 <= mean[1] < self.height
        good = (step.ok and inside and colour <= cfg.lost_colour
                and not self._someone_else(boxes, p, mean))
        self.bad = 0 if good else self.bad + 1
        if good:  # Menezes eq. 13, per patch
            self.refs = update_reference(self.refs, seen, self.kappa)
        if self.bad >= cfg.lost_frames or not inside:
            self.state = "lost"
        cov = self.pf.cov
        conf = float(p.max()) if len(p) and self.recogniser is not None else np.nan
        return IcuStep(self.state, mean, float(np.sqrt(cov[0, 0] + cov[1, 1])),
                       self.pf.particles, np.exp(self.pf.log_weights), boxes, conf, p, colour)
