"""The ICU tracker as a pipeline stage: one camera's frames -> ``tracks2d`` (the tutor, with
the state machine's state), scored as ``trackers.<name>.*`` against the projected true head."""

from __future__ import annotations

import numpy as np

from humimic.messages import Track2D, Tracks2D
from humimic.perception.trackers.common import HEAD_WIDTH_M, ImageTrackerStage, Overlay


class IcuStage(ImageTrackerStage):
    def __init__(self, name: str, cfg, camera: str, tracker, identity: str, gt, rlog=None,
                 people=None):
        super().__init__(name, camera, "head", HEAD_WIDTH_M, gt, rlog, cfg.latency, people)
        self.tracker, self.identity = tracker, identity

    def track(self, t: float, image: np.ndarray):
        s = self.tracker.step(image)
        u, v, scale = (float(x) for x in s.mean)
        state = "tracking" if s.state == "tracking" else s.state
        tracks = Tracks2D(self.tracker_name, self.camera, (Track2D(
            "person", u, v, scale, 0.0, state, self.identity, s.confidence, s.spread_px),),
            s.state)
        contour = None
        if np.all(np.isfinite(s.mean)):
            contour = self.tracker.template.place(s.mean)[0][0]
        good = s.state == "tracking" and not (np.isfinite(s.confidence) and s.confidence < 0.5)
        overlay = Overlay(None if s.particles is None else s.particles[:, :2], s.weights,
                          contour, good, s.faces)
        return tracks, overlay
