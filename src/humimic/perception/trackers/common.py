"""What every tracker kind shares: where a scenario error points, which camera(s) a tracker
watches, the scenario's skin colour model as a lookup table, the stage classes with the
``frames`` subscription and per-frame compute timing, and the metrics every tracker reports
(``frames_per_s``, ``lost_fraction``).

* :class:`PoseTrackerStage` (3-D and articulated kinds): implement ``track(t, images)``
  returning a :class:`~humimic.messages.PoseEstimate` (published on ``poses``) and ``scores()``.
* :class:`ImageTrackerStage` (image-space kinds): implement ``track(t, image)`` returning
  ``(Tracks2D, Overlay | None)``; published on ``tracks2d``, scored against projected ground
  truth (:mod:`humimic.metrics.tracks2d`; visibility from :mod:`humimic.sensors.visibility`:
  in view and unoccluded, so another person in front hides the target), drawn in rerun
  (particles coloured by weight, the estimate green while tracking and red otherwise,
  detections in yellow, the state over time).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from humimic.errors import closest
from humimic.messages import TRACK_STATES, Tracks2D
from humimic.metrics.tracks2d import ImageTruth, project_truth, scores
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.auto_colors import NotInView, file_lut, learned_lut, look_alike_report
from humimic.perception.cues.color_models import ColorLUT
from humimic.pipeline.stage import Stage
from humimic.scenario.errors import ScenarioError
from humimic.sensors.camera_model import invert_transform
from humimic.viz.plots import plot_errors, plot_track2d
from humimic.viz.rerun_log import EVENTS, PIXEL_CENTRE_SHIFT, SERIES, image_entity

GOOD, BAD, DETECTION = (40, 200, 60), (230, 40, 40), (255, 220, 0)
HEAD_WIDTH_M = 0.156
"""The avatar's head is 15.6 cm wide seen from the front."""


def where(scenario) -> str:
    return f"scenario {scenario.name!r}"


def skin_model_lut(scenario, world, cameras, key: str, bits: int = 6,
                   gains: tuple[float, ...] = (1.0,),
                   background_ratio: float | None = None) -> ColorLUT:
    """The skin colour model as a :class:`ColorLUT`: the file ``perception.color_model`` names,
    or (``auto``, the default, and without a ``perception`` section) the model learned for
    this scenario's person as ``cameras`` see them (:func:`~humimic.perception.cues.
    auto_colors.learned_lut`, cached on disk; their pixels also under each of ``gains``; its
    background cut by ``background_ratio``, :func:`~humimic.perception.cues.auto_colors.
    cut_background`). ``key`` names the tracker in errors."""
    cfg = getattr(scenario, "perception", None)
    source = cfg.color_model if cfg is not None else "auto"
    try:
        if source == "auto":
            return learned_lut(world, list(cameras), "skin", "rgb", bits, gains,
                               background_ratio).lut
        return file_lut(Path(source), bits).lut
    except NotInView as err:
        raise ScenarioError(where(scenario), key, f"cannot learn the skin colours: {err}",
                            "auto", f"perception.color_model: {DEFAULT_COLOR_MODEL}") from None
    except (OSError, ValueError) as err:
        raise ScenarioError(where(scenario), key, f"skin colour model unreadable: {err}",
                            str(source), "a file written by humimic.perception.cues."
                            "learn_colors") from None


def check_cameras(scenario, world, name: str, cameras, needed: int, key: str = "cameras"
                  ) -> tuple[str, ...]:
    """The cameras a tracker uses (``cameras`` or the first ``needed`` rendered eyes); a
    camera that is not rendered is a :class:`ScenarioError` naming the key
    (``trackers.<name>.<key>``)."""
    where = f"scenario {scenario.name!r}"
    cams = tuple(cameras) if cameras is not None else tuple(world.eye_cameras[:needed])
    if len(cams) < needed:
        raise ScenarioError(where, f"trackers.{name}.{key}",
                            f"this tracker needs {needed} camera(s)", list(cams),
                            "cameras.eyes: stereo")
    for i, cam in enumerate(cams):
        if cam not in world.eye_cameras:
            raise ScenarioError(where, f"trackers.{name}.{key}.{i}",
                                f"camera {cam!r} is not rendered by this scenario", cam,
                                f"{', '.join(world.eye_cameras) or 'none'} (set cameras.which)")
    return cams


def check_camera(scenario, world, name: str, camera: str | None) -> str:
    """The one camera of a 2-D tracker (``trackers.<name>.camera`` or the first eye)."""
    if camera is None:
        return check_cameras(scenario, world, name, None, 1)[0]
    if camera not in world.eye_cameras:
        raise ScenarioError(f"scenario {scenario.name!r}", f"trackers.{name}.camera",
                            f"camera {camera!r} is not rendered by this scenario", camera,
                            f"{', '.join(world.eye_cameras) or 'none'} (set cameras.which)",
                            closest(camera, world.eye_cameras))
    return camera


class PoseTrackerStage(Stage):
    """Runs a tracker on every frame set, publishes ``poses`` (photon time of the frame, ready
    ``latency`` later), keeps the estimates (``self.times``, ``self.estimates``) and times the
    per-frame compute (``frames_per_s`` excludes rendering)."""

    kind = "tracker"
    skin_lut = None
    """The skin :class:`ColorLUT` the tracker uses, if any: its look-alike ratio is scored."""

    def __init__(self, name: str, latency: float = 0.0):
        self.name = f"trackers.{name}"
        self.tracker_name = name
        self.latency = float(latency)
        self.times: list[float] = []
        self.estimates: list = []
        self.compute_s = 0.0
        self._bus = self._timer = None

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic: str, msg) -> None:
        t0 = time.perf_counter()
        est = self.track(msg.t, msg.value)
        dt = time.perf_counter() - t0
        self.compute_s += dt
        if self._timer is not None:
            self._timer.add(self.name, dt)
        self.times.append(msg.t)
        self.estimates.append(est)
        if est is not None:
            self._bus.publish("poses", msg.then(est, self.latency))

    def track(self, t: float, images: dict):  # pragma: no cover - abstract
        raise NotImplementedError

    def scores(self) -> dict:
        return {}

    def error_series(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Per-frame errors (m) by label, ``(times, errors)``, NaN where not judged: what
        :meth:`plots` draws (none by default)."""
        return {}

    def plots(self, out_dir) -> list:
        return pose_error_plot(out_dir, self.tracker_name, self.error_series())

    def metrics(self) -> dict:
        n = len(self.times)
        lost = [e is None or e.status != "tracking" for e in self.estimates]
        out = {"kind": self.kind, "frames": n,
               "frames_per_s": n / self.compute_s if self.compute_s > 0 else None,
               "lost_fraction": float(np.mean(lost)) if n else None}
        out.update(self.scores())
        if self.skin_lut is not None:
            out.update(look_alike_report(self.skin_lut.look_alike, self.skin_lut.class_lost))
        return {"trackers": {self.tracker_name: out}}


def pose_error_plot(out_dir, name: str, series: dict) -> list:
    """``tracker_<name>.png``: a 3-D tracker's per-frame errors (m, drawn in mm) over time."""
    if not series:
        return []
    t0 = next(iter(series.values()))[0]
    mm = {label: (np.asarray(t), 1e3 * np.asarray(e)) for label, (t, e) in series.items()}
    return [plot_errors(Path(out_dir) / f"tracker_{name}.png", t0, mm,
                        title=f"{name}: error against the avatar's truth", ylabel="mm")]


@dataclass(frozen=True)
class Overlay:
    """What one frame shows on the camera image."""

    particles: np.ndarray | None = None
    """(N, 2) particle centres (px)."""
    weights: np.ndarray | None = None
    contour: np.ndarray | None = None
    """(M, 2) the estimate's outline (px), closed."""
    good: bool = True
    detections: np.ndarray | None = None
    """(K, 4) detection boxes x, y, w, h (px)."""


def weight_colors(w: np.ndarray) -> np.ndarray:
    """Particles' colours from their weights: dark blue (least) to yellow (largest)."""
    w = np.asarray(w, float)
    x = w / w.max() if w.size and w.max() > 0 else np.zeros_like(w)
    return np.column_stack([40 + 215 * x, 40 + 180 * x, 160 * (1 - x)]).astype(np.uint8)


class ImageTrackerStage(Stage):
    """Runs a 2-D tracker on one camera's frames, publishes ``tracks2d`` (photon time of the
    frame, ready ``latency`` later), keeps every frame's camera and tracks, times the tracker's
    compute (``frames_per_s`` excludes rendering) and scores its first track against the
    ground truth of ``target`` (a site of physical size ``size_m``)."""

    skin_lut = None
    """The skin :class:`ColorLUT` the tracker uses, if any: its look-alike ratio is scored."""

    def __init__(self, name: str, camera: str, target: str, size_m: float, gt, rlog=None,
                 latency: float = 0.0, people=None, visibility=None):
        self.name = f"trackers.{name}"
        self.tracker_name, self.camera, self.target, self.size_m = name, camera, target, size_m
        self.gt, self.rlog, self.latency = gt, rlog, float(latency)
        self.people = people
        """The other people's motion (:class:`humimic.world.people.PeopleMotion`) or None."""
        self.visibility = visibility
        """The world's :class:`~humimic.sensors.visibility.Visibility` (None: the target is
        visible whenever its centre projects into the image)."""
        self.times: list[float] = []
        self.cameras: list = []
        self.tracks: list[Tracks2D] = []
        self.compute_s = 0.0
        self._last_state = ""
        self._bus = self._timer = None

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic: str, msg) -> None:
        image = msg.value.get(self.camera)
        if image is None:
            return
        t0 = time.perf_counter()
        tracks, overlay = self.track(msg.t, image.image)
        dt = time.perf_counter() - t0
        self.compute_s += dt
        if self._timer is not None:
            self._timer.add(self.name, dt)
        self.times.append(msg.t)
        self.cameras.append(image.camera)
        self.tracks.append(tracks)
        self._bus.publish("tracks2d", msg.then(tracks, self.latency))
        if self.rlog is not None and self.rlog.enabled:
            self._draw(msg.t, tracks, overlay)

    def track(self, t: float, image: np.ndarray):  # pragma: no cover - abstract
        raise NotImplementedError

    # ---- rerun -------------------------------------------------------------------------------
    def _draw(self, t: float, tracks: Tracks2D, ov: Overlay | None) -> None:
        base = f"{image_entity(self.camera)}/{self.tracker_name}"
        state = tracks.state or (tracks.tracks[0].state if tracks.tracks else "")
        if state != self._last_state:
            self.rlog.log_text(t, f"{EVENTS}/{self.tracker_name}",
                               f"{self._last_state or 'start'} -> {state}")
            self._last_state = state
        if ov is None:
            return
        if ov.particles is not None:
            self.rlog.log(t, f"{base}/particles", rr.Points2D(
                ov.particles + PIXEL_CENTRE_SHIFT, colors=weight_colors(ov.weights), radii=1.0))
        strips = [] if ov.contour is None else [np.vstack([ov.contour, ov.contour[:1]])
                                                + PIXEL_CENTRE_SHIFT]
        self.rlog.log(t, f"{base}/estimate", rr.LineStrips2D(
            strips, colors=GOOD if ov.good else BAD, radii=1.0))
        boxes = np.zeros((0, 4)) if ov.detections is None else np.asarray(ov.detections)
        self.rlog.log(t, f"{base}/detections", rr.Boxes2D(
            mins=boxes[:, :2] + PIXEL_CENTRE_SHIFT, sizes=boxes[:, 2:], colors=DETECTION))

    def _state_codes(self) -> np.ndarray:
        return np.array([TRACK_STATES.index(tr.tracks[0].state) if tr.tracks else 0
                         for tr in self.tracks], float)

    def plots(self, out_dir) -> list:
        """``tracker_<name>.png``: the centre error over time, hidden frames shaded, and the
        state."""
        if not self.times:
            return []
        uv, _, _, truth = self.arrays()
        return [plot_track2d(Path(out_dir) / f"tracker_{self.tracker_name}.png",
                             np.array(self.times), np.linalg.norm(uv - truth.uv, axis=1),
                             truth.visible, self._state_codes(), TRACK_STATES,
                             f"{self.tracker_name}: {self.target} on {self.camera}")]

    def log(self, rlog) -> None:
        if not self.times:
            return
        code = self._state_codes()
        rlog.log_series(f"{SERIES}/trackers/{self.tracker_name}/state", np.array(self.times),
                        code, names=["state (0 init, 1 tracking, 2 lost)"])
        uv, _, _, truth = self.arrays()
        err = np.linalg.norm(uv - truth.uv, axis=1)
        rlog.log_series(f"{SERIES}/trackers/{self.tracker_name}/error_px", np.array(self.times),
                        err, names=["centre error (px)"])

    # ---- scores ------------------------------------------------------------------------------
    def arrays(self):
        """``(uv (F, 2), scale (F,), tracking (F,), truth)`` of the first track per frame."""
        F = len(self.times)
        uv, scale, tracking = np.full((F, 2), np.nan), np.full(F, np.nan), np.zeros(F, bool)
        for k, tr in enumerate(self.tracks):
            if tr.tracks:
                a = tr.tracks[0]
                uv[k], scale[k], tracking[k] = (a.u, a.v), a.scale, a.state == "tracking"
        idx = self.gt.index_of(np.array(self.times))
        truth = project_truth(self.cameras, self.gt.p_base(self.target)[idx], self.size_m)
        vis = self.visibility.arrays() if self.visibility is not None else None
        if vis is not None and len(vis.t) and self.target in vis.targets:
            seen = vis.visible[vis.at(np.array(self.times)), vis.camera(self.camera),
                               vis.target(self.target)]
            truth = ImageTruth(truth.uv, truth.size_px, seen & (truth.depth > 0), truth.depth)
        return uv, scale, tracking, truth

    #: The other people's parts scored against (site of :data:`SKIN_SITES`, width m).
    other_sites: tuple[tuple[str, float], ...] = (("head", HEAD_WIDTH_M),)

    def others(self) -> list:
        """Projected truths of the other people's :attr:`other_sites` (``human.people``), for
        occlusion and identity switches."""
        if self.people is None:
            return []
        t = np.array(self.times)
        T_base_world = invert_transform(self.gt.T_world_base)
        out = []
        for k in range(len(self.people.people)):
            for site, size in self.other_sites:
                p = (self.people.site_world(k, site, t) @ T_base_world[:3, :3].T
                     + T_base_world[:3, 3])
                out.append(project_truth(self.cameras, p, size))
        return out

    def metrics(self) -> dict:
        n = len(self.times)
        out = {"frames": n, "camera": self.camera, "target": self.target,
               "frames_per_s": n / self.compute_s if self.compute_s > 0 else None,
               "lost_fraction": None}
        if n:
            uv, scale, tracking, truth = self.arrays()
            out.update(scores(np.array(self.times), uv, scale, tracking, truth, self.others()))
            out["hidden_frames"] = int(np.sum(~truth.visible))
        if self.skin_lut is not None:
            out.update(look_alike_report(self.skin_lut.look_alike, self.skin_lut.class_lost))
        return {"trackers": {self.tracker_name: out}}
