"""The ICU tracker as a pipeline stage: one camera's frames -> ``tracks2d`` (the tutor, with
the state machine's state), scored as ``trackers.<name>.*`` against the projected true head;
with ``near``, Fig. 15's module switch (``trackers.<name>.modules``)."""

from __future__ import annotations

import numpy as np

from humimic.messages import Track2D, Tracks2D
from humimic.perception.trackers.common import HEAD_WIDTH_M, ImageTrackerStage, Overlay
from humimic.perception.trackers.frame_cues import load_kernels
from humimic.perception.trackers.icu.modules import (
    MODULES,
    GatedStage,
    head_distance_m,
    module_scores,
    next_module,
)
from humimic.viz.rerun_log import SERIES


class IcuStage(ImageTrackerStage):
    def __init__(self, name: str, cfg, camera: str, tracker, identity: str, gt, rlog=None,
                 people=None, visibility=None, fx_px: float | None = None):
        super().__init__(name, camera, "head", HEAD_WIDTH_M, gt, rlog, cfg.latency, people,
                         visibility)
        self.tracker, self.identity, self.skin_lut = tracker, identity, tracker.skin
        load_kernels(None, cfg.bins)     # numba's cue kernels, before frame one
        self.near, self.fx_px = cfg.near, fx_px
        self.module = "init"
        self.last_good, self.distance = -np.inf, np.inf
        """When the tutor was last tracked and recognised, and the distance then (m)."""
        self.modules: list[str] = []
        """Fig. 15's module per frame (:data:`MODULES`), with ``near`` configured."""
        self.faces: list[tuple[int, np.ndarray, np.ndarray]] = []
        """(frame index, face boxes, their probabilities of being the tutor) per frame."""

    def track(self, t: float, image: np.ndarray):
        s = self.tracker.step(image)
        if len(s.faces):
            self.faces.append((len(self.times), s.faces, s.probabilities))
        u, v, scale = (float(x) for x in s.mean)
        state = "tracking" if s.state == "tracking" else s.state
        tracks = Tracks2D(self.tracker_name, self.camera, (Track2D(
            "person", u, v, scale, 0.0, state, self.identity, s.confidence, s.spread_px),),
            s.state)
        contour = None
        if np.all(np.isfinite(s.mean)):
            contour = self.tracker.template.place(s.mean)[0][0]
        good = s.state == "tracking" and not (
            np.isfinite(s.confidence) and s.confidence < self.tracker.cfg.min_confidence)
        if self.near is not None:
            if good:
                self.last_good, self.distance = t, head_distance_m(self.fx_px, scale,
                                                                   HEAD_WIDTH_M)
            tracked = t - self.last_good <= self.near.hold_s
            self.module = next_module(self.module, tracked, self.distance,
                                      self.near.enter_m, self.near.leave_m)
            self.modules.append(self.module)
        overlay = Overlay(None if s.particles is None else s.particles[:, :2], s.weights,
                          contour, good, s.faces)
        return tracks, overlay

    def wire(self, stages: list) -> list:
        """The stages with the near module's gated: it gets frames only in ``near`` (one
        frame late if it is listed before this tracker)."""
        if self.near is None:
            return stages
        return [GatedStage(st, lambda: self.module == "near")
                if getattr(st, "tracker_name", None) == self.near.module else st
                for st in stages]

    def log(self, rlog) -> None:
        super().log(rlog)
        if self.modules:
            code = [MODULES.index(m) for m in self.modules]
            rlog.log_series(f"{SERIES}/trackers/{self.tracker_name}/module",
                            np.array(self.times), np.array(code, float),
                            names=["module (0 init, 1 icu, 2 near)"])

    def metrics(self) -> dict:
        out = super().metrics()
        if self.modules:
            _, _, _, truth = self.arrays()
            near = self.near
            out["trackers"][self.tracker_name]["modules"] = {
                "near_module": near.module, **module_scores(
                    np.array(self.times), self.modules, truth.depth, truth.visible,
                    near.enter_m, near.leave_m)}
        out["trackers"][self.tracker_name]["window_restarts"] = self.tracker.restarts
        if self.tracker.recogniser is not None and self.times:
            _, _, _, truth = self.arrays()
            out["trackers"][self.tracker_name]["recognition"] = recognition_counts(
                self.faces, truth, self.others(), self.tracker.cfg.min_confidence)
        return out


def recognition_counts(faces, truth, others, threshold: float) -> dict[str, int]:
    """Confusion counts of the detected faces: whose face each is (the projected head within
    half a head width of the box centre: the tutor, another person, or nobody -- a false
    detection) against whether it was taken for the tutor (probability >= ``threshold``)."""
    out = dict.fromkeys(("tutor_accepted", "tutor_rejected", "other_accepted",
                         "other_rejected", "false_detection"), 0)
    for k, boxes, p in faces:
        centres = boxes[:, :2] + boxes[:, 2:] / 2.0
        for c, prob in zip(centres, p, strict=True):
            yes = "accepted" if prob >= threshold else "rejected"
            if _near(c, truth, k):
                out[f"tutor_{yes}"] += 1
            elif any(_near(c, o, k) for o in others):
                out[f"other_{yes}"] += 1
            else:
                out["false_detection"] += 1
    return out


def _near(c: np.ndarray, truth, k: int) -> bool:
    return bool(truth.depth[k] > 0 and np.hypot(*(c - truth.uv[k])) < 0.5 * truth.size_px[k])
