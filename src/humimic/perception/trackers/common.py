"""What every tracker stage shares: the ``frames`` subscription with per-frame compute timing,
the ``poses`` publication, the record of estimates, and the metrics every tracker reports
(``frames_per_s``, ``lost_fraction``).

A tracker kind subclasses :class:`PoseTrackerStage` and implements ``track(t, images)``
returning a :class:`~humimic.messages.PoseEstimate` (or None to publish nothing), and
``scores()`` for its own errors against the ground truth.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from humimic.perception.cues.color_models import ColorLUT
from humimic.perception.cues.edges import edge_maps
from humimic.perception.cues.histograms import QuantizedImage, quantize
from humimic.perception.cues.motion import MotionEdgeMaps, motion_edge_maps
from humimic.pipeline.stage import Stage
from humimic.scenario.errors import ScenarioError
from humimic.sensors.camera_model import CameraImage, Intrinsics, invert_transform


@dataclass(frozen=True)
class FrameCues:
    """One camera frame's cue images, computed once per frame for all particles."""

    intrinsics: Intrinsics
    T_cam_base: np.ndarray
    maps: MotionEdgeMaps
    """Canny edges, moving edges (empty without optical flow) and their distance transforms."""
    skin: np.ndarray | None
    """float32 skin posterior per pixel (None without a skin model)."""
    qimage: QuantizedImage
    edge_density: float
    """Fraction of edge pixels."""

    @property
    def dt(self) -> np.ndarray:
        return self.maps.dt


def frame_cues(frame: CameraImage, bins: int, lut: ColorLUT | None = None,
               flow: np.ndarray | None = None) -> FrameCues:
    """The cue images of ``frame``: edges (and moving edges with ``flow``), skin posterior,
    quantised colours."""
    maps = edge_maps(frame.image)
    return FrameCues(frame.camera.intrinsics, invert_transform(frame.camera.T_base_cam),
                     motion_edge_maps(maps, flow), None if lut is None else
                     lut.posterior(frame.image), quantize(frame.image, bins),
                     float(np.mean(maps.edges > 0)))


def check_cameras(scenario, world, name: str, cameras, needed: int,
                  key: str = "cameras") -> tuple[str, ...]:
    """The cameras a tracker uses (``cameras`` or the first ``needed`` rendered eyes); a
    camera that is not rendered is a :class:`ScenarioError` naming the key
    (``trackers.<name>.<key>``, with the index when ``key`` is a list)."""
    where = f"scenario {scenario.name!r}"
    cams = tuple(cameras) if cameras is not None else tuple(world.eye_cameras[:needed])
    if len(cams) < needed:
        raise ScenarioError(where, f"trackers.{name}.{key}",
                            f"this tracker needs {needed} camera(s)", list(cams),
                            "cameras.eyes: stereo")
    for i, cam in enumerate(cams):
        if cam not in world.eye_cameras:
            where_key = f"trackers.{name}.{key}" + (f".{i}" if needed > 1 else "")
            raise ScenarioError(where, where_key,
                                f"camera {cam!r} is not rendered by this scenario", cam,
                                f"{', '.join(world.eye_cameras) or 'none'} (set cameras.which)")
    return cams


class PoseTrackerStage(Stage):
    """Runs a tracker on every frame set, publishes ``poses`` (photon time of the frame, ready
    ``latency`` later), keeps the estimates (``self.times``, ``self.estimates``) and times the
    per-frame compute (``frames_per_s`` excludes rendering)."""

    kind = "tracker"

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

    def metrics(self) -> dict:
        n = len(self.times)
        lost = [e is None or e.status != "tracking" for e in self.estimates]
        out = {"kind": self.kind, "frames": n,
               "frames_per_s": n / self.compute_s if self.compute_s > 0 else None,
               "lost_fraction": float(np.mean(lost)) if n else None}
        out.update(self.scores())
        return {"trackers": {self.tracker_name: out}}
