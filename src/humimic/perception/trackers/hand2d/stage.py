"""The hand tracker as a pipeline stage: one camera's frames -> ``tracks2d`` (one track, the
hand), scored as ``trackers.<name>.*`` against the projected true hand."""

from __future__ import annotations

import numpy as np

from humimic.messages import Track2D, Tracks2D
from humimic.perception.trackers.common import HEAD_WIDTH_M, ImageTrackerStage, Overlay
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker
from humimic.perception.trackers.hand2d.warmup import load_kernels

HAND_WIDTH_M = 0.09
"""The avatar's hand seen palm-on is 9 cm wide (``models/avatar.xml``): the true scale."""


class Hand2DStage(ImageTrackerStage):
    def __init__(self, name: str, cfg, camera: str, tracker: Hand2DTracker, gt, rlog=None,
                 visibility=None, people=None):
        super().__init__(name, camera, cfg.target, HAND_WIDTH_M, gt, rlog, cfg.latency,
                         people, visibility)
        self.cfg, self.tracker, self.skin_lut = cfg, tracker, tracker.lut
        load_kernels(cfg, tracker.lut)   # numba's kernels, before frame one

    def metrics(self) -> dict:
        """The common scores plus ``others_near_frames``: frames where another person's face
        or hand is in view within 3 hand widths of the tutor's hand (the distraction)."""
        out = super().metrics()
        if self.times and self.people is not None:
            _, _, _, truth = self.arrays()
            near = np.zeros(len(self.times), bool)
            for o in self.others():
                with np.errstate(invalid="ignore"):
                    near |= o.visible & (np.linalg.norm(o.uv - truth.uv, axis=1)
                                         < 3.0 * truth.size_px)
            out["trackers"][self.tracker_name]["others_near_frames"] = int(near.sum())
        return out

    #: The other people's face and hands: the skin the tracker must not take for the tutor's
    #: hand (identity switches, wrong-person frames).
    other_sites = (("head", HEAD_WIDTH_M), ("r_hand", HAND_WIDTH_M), ("l_hand", HAND_WIDTH_M))

    def track(self, t: float, image: np.ndarray):
        s = self.tracker.step(image)
        u, v, scale, angle = (float(x) for x in s.mean)
        tracks = Tracks2D(self.tracker_name, self.camera, (Track2D(
            self.cfg.target, u, v, scale, angle, s.state, spread_px=s.spread_px),))
        contour = None
        if np.all(np.isfinite(s.mean)):
            contour = self.tracker.template.place(s.mean)[0][0]
        overlay = Overlay(
            None if s.particles is None else s.particles[:, :2], s.weights, contour,
            s.state == "tracking", None if s.blobs is None else s.blobs.boxes)
        return tracks, overlay
