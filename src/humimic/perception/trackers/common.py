"""What every tracker kind shares: where a scenario error points, which eye camera(s) a
tracker watches, the scenario's skin colour model as a lookup table; the ``frames``
subscription with per-frame compute timing, the ``poses`` publication, the record of estimates,
and the metrics every tracker reports (``frames_per_s``, ``lost_fraction``).

A tracker kind subclasses :class:`PoseTrackerStage` and implements ``track(t, images)``
returning a :class:`~humimic.messages.PoseEstimate` (or None to publish nothing), and
``scores()`` for its own errors against the ground truth.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.pipeline.stage import Stage
from humimic.scenario.errors import ScenarioError


def where(scenario) -> str:
    return f"scenario {scenario.name!r}"


def tracker_camera(scenario, world, name: str, camera: str | None) -> str:
    """The eye camera tracker ``name`` watches (its ``camera`` or the first rendered one)."""
    if not world.eye_cameras:
        raise ScenarioError(where(scenario), f"trackers.{name}", "the tracker needs an eye "
                            "camera and none is rendered", None, "cameras.enabled: true")
    if camera is None:
        return world.eye_cameras[0]
    if camera not in world.eye_cameras:
        raise ScenarioError(where(scenario), f"trackers.{name}.camera", "camera not rendered "
                            "by this scenario", camera, ", ".join(world.eye_cameras))
    return camera


def skin_model_lut(scenario, key: str, bits: int = 6) -> ColorLUT:
    """The skin colour model perception uses (``perception.color_model``, default
    ``models/colors/skin.json``) as a :class:`ColorLUT`; ``key`` names the tracker in errors."""
    cfg = getattr(scenario, "perception", None)
    path = Path(cfg.color_model if cfg is not None and cfg.color_model else DEFAULT_COLOR_MODEL)
    try:
        return ColorLUT(load_color_model(path), bits)
    except (OSError, ValueError) as err:
        raise ScenarioError(where(scenario), key, f"skin colour model unreadable: {err}",
                            str(path), "a file written by humimic.perception.cues.learn_colors"
                            ) from None


def check_cameras(scenario, world, name: str, cameras, needed: int) -> tuple[str, ...]:
    """The cameras a tracker uses (``cameras`` or the first ``needed`` rendered eyes); a
    camera that is not rendered is a :class:`ScenarioError` naming the key."""
    where = f"scenario {scenario.name!r}"
    cams = tuple(cameras) if cameras is not None else tuple(world.eye_cameras[:needed])
    if len(cams) < needed:
        raise ScenarioError(where, f"trackers.{name}.cameras",
                            f"this tracker needs {needed} camera(s)", list(cams),
                            "cameras.eyes: stereo")
    for i, cam in enumerate(cams):
        if cam not in world.eye_cameras:
            raise ScenarioError(where, f"trackers.{name}.cameras.{i}",
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
