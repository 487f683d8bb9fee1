"""The hand tracker as a pipeline stage: one camera's frames -> ``tracks2d`` (one track, the
hand), scored as ``trackers.<name>.*`` against the projected true hand."""

from __future__ import annotations

import numpy as np

from humimic.messages import Track2D, Tracks2D
from humimic.metrics.tracks2d import project_truth
from humimic.perception.trackers.common import HEAD_WIDTH_M, ImageTrackerStage, Overlay
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker
from humimic.sensors.camera_model import invert_transform

HAND_WIDTH_M = 0.09
"""The avatar's hand seen palm-on is 9 cm wide (``models/avatar.xml``): the true scale."""


class Hand2DStage(ImageTrackerStage):
    def __init__(self, name: str, cfg, camera: str, tracker: Hand2DTracker, gt, rlog=None,
                 visibility=None, people=None):
        super().__init__(name, camera, cfg.target, HAND_WIDTH_M, gt, rlog, cfg.latency,
                         people, visibility)
        self.cfg, self.tracker = cfg, tracker

    def others(self) -> list:
        """The other people's face and hands projected (``human.people``): the skin the
        tracker must not take for the tutor's hand (identity switches, wrong-person frames)."""
        if self.people is None:
            return []
        t = np.array(self.times)
        T_base_world = invert_transform(self.gt.T_world_base)
        out = []
        for k in range(len(self.people.people)):
            for site, size in (("head", HEAD_WIDTH_M), ("r_hand", HAND_WIDTH_M),
                               ("l_hand", HAND_WIDTH_M)):
                p = (self.people.site_world(k, site, t) @ T_base_world[:3, :3].T
                     + T_base_world[:3, 3])
                out.append(project_truth(self.cameras, p, size))
        return out

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
