"""Sensor faults, injected into what the sensors publish: lost, frozen and covered camera frames
and lost inertial samples. Seeded from the scenario's :class:`~humimic.rngs.Rngs`.

The sensors render and sample as if nothing were wrong; the faults act on the published values,
as a transfer link or a lens cover would:

* ``cameras.drop_rate``: a stereo frame set is lost in transfer with this probability (the
  capture is synchronised, so both images go). Nothing is published: downstream stages see a
  gap in the frame times, and the filter predicts across it at the next frame.
* ``cameras.freeze_rate``: with this probability, per camera and frame, a camera delivers its
  previous image again (stale pixels under a new time stamp, as a frame grabber that missed a
  buffer swap does). The eyes' pose is the current one: the system cannot tell.
* ``cameras.covered``: a camera's image is black during a time window (a hand over the lens).
* ``sensors.imu.drop_rate`` / ``sensors.wiimote.drop_rate``: an inertial sample is lost.

Every frame draws the same random numbers whatever happens to it (one for the drop, one per
camera for the freeze), so one fault's rate never shifts another's pattern. The counts seen are
reported under ``faults`` (``frames_dropped``, ``frames_frozen``, ``frames_covered``,
``<sensor>_samples_dropped``); :meth:`FrameFaults.status` tells ground-truth stages (the oracle)
what happened to a frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.scenario.errors import ScenarioError
from humimic.sensors.camera_model import CameraImage
from humimic.world.names import EYE_CAMERAS

#: Inertial sensors with a ``drop_rate`` (bus topic -> ``sensors`` key).
INERTIAL = {"imu": "imu", "wiimote": "wiimote"}


@dataclass(frozen=True)
class FrameStatus:
    """What the faults did to one camera's frame."""

    frozen: bool = False
    covered: bool = False
    t_content: float = 0.0
    """Capture time (s) of the pixels delivered (earlier than the frame's time if frozen)."""


def in_window(t: float, windows: list[tuple[float, float]]) -> bool:
    """Whether ``t`` lies in any half-open window ``[start, end)``."""
    return any(start <= t < end for start, end in windows)


def keep_samples(n: int, drop_rate: float, rng: np.random.Generator) -> np.ndarray:
    """``(n,)`` bool: which of ``n`` samples survive independent losses at ``drop_rate``."""
    if drop_rate <= 0.0:
        return np.ones(n, bool)
    return rng.random(n) >= drop_rate


class FrameFaults:
    """Faults of a camera rig's published frames (see the module docstring).

    ``covered`` maps a camera name to its black windows ``[(start, end), ...]`` (s).
    """

    def __init__(self, cameras: list[str], drop_rate: float = 0.0, freeze_rate: float = 0.0,
                 covered: dict[str, list[tuple[float, float]]] | None = None,
                 rng: np.random.Generator | None = None):
        self.cameras = list(cameras)
        self.drop_rate, self.freeze_rate = float(drop_rate), float(freeze_rate)
        self.covered = {c: list(w) for c, w in (covered or {}).items() if w}
        self.rng = rng
        if (self.drop_rate > 0.0 or self.freeze_rate > 0.0) and rng is None:
            raise ValueError("random faults need a random generator")
        self._last: dict[str, tuple[np.ndarray, float]] = {}
        self._status: dict[float, dict[str, FrameStatus]] = {}
        self.frames = 0
        self.dropped = 0
        self.frozen = dict.fromkeys(self.cameras, 0)
        self.blacked = dict.fromkeys(self.cameras, 0)

    @property
    def active(self) -> bool:
        return self.drop_rate > 0.0 or self.freeze_rate > 0.0 or bool(self.covered)

    def apply(self, t: float, images: dict[str, CameraImage]) -> dict[str, CameraImage] | None:
        """The frame set as published at time ``t``, or None if it is lost."""
        self.frames += 1
        if not self.active:
            return images
        u = (self.rng.random(1 + len(self.cameras)) if self.rng is not None
             else np.ones(1 + len(self.cameras)))
        out, status = {}, {}
        for i, name in enumerate(self.cameras):
            img = images[name]
            pixels, t_content = img.image, img.t
            frozen = covered = False
            if in_window(t, self.covered.get(name, ())):
                pixels, covered = np.zeros_like(img.image), True
                self.blacked[name] += 1
            elif u[1 + i] < self.freeze_rate and name in self._last:
                (pixels, t_content), frozen = self._last[name], True
                self.frozen[name] += 1
            self._last[name] = (pixels, t_content)
            out[name] = img if pixels is img.image else CameraImage(img.t, img.camera, pixels)
            if frozen or covered:
                status[name] = FrameStatus(frozen, covered, t_content)
        if status:
            self._status[t] = status
        if u[0] < self.drop_rate:
            self.dropped += 1
            return None
        return out

    def status(self, t: float, camera: str) -> FrameStatus | None:
        """What happened to ``camera``'s frame at time ``t`` (None: delivered as captured)."""
        return self._status.get(t, {}).get(camera)

    def metrics(self) -> dict:
        return {"frames": self.frames, "frames_dropped": self.dropped,
                "frames_frozen": dict(self.frozen), "frames_covered": dict(self.blacked)}


class SensorFaults:
    """Every fault a scenario configures: the eye cameras' frames and the inertial samples."""

    def __init__(self, scenario, eye_cameras: list[str], rngs):
        c = scenario.cameras
        covered: dict[str, list[tuple[float, float]]] = {}
        for i, w in enumerate(c.covered):
            eyes = ("left", "right") if w.camera == "both" else (w.camera,)
            for eye in eyes:
                name = EYE_CAMERAS[(eye, c.which)]
                if name not in eye_cameras:
                    raise ScenarioError(f"scenario {scenario.name!r}", f"cameras.covered.{i}."
                                        "camera", f"the {eye} eye has no camera in this "
                                        f"scenario (cameras.eyes: {c.eyes})", w.camera,
                                        "a camera the scenario has")
                covered.setdefault(name, []).append((w.start, w.end))
        random = c.drop_rate > 0.0 or c.freeze_rate > 0.0
        self.frames = FrameFaults(eye_cameras, c.drop_rate, c.freeze_rate, covered,
                                  rngs["faults.cameras"] if random else None)
        self._inertial = {topic: (getattr(scenario.sensors, key).drop_rate, rngs,
                                  f"faults.{topic}")
                          for topic, key in INERTIAL.items()}
        self.samples: dict[str, tuple[int, int]] = {}

    def keep(self, topic: str, n: int) -> np.ndarray:
        """Which of the ``n`` samples of an inertial sensor are published (counted)."""
        rate, rngs, name = self._inertial[topic]
        keep = keep_samples(n, rate, rngs[name] if rate > 0.0 else None)
        self.samples[topic] = (n, int(n - keep.sum()))
        return keep

    def metrics(self) -> dict:
        out = self.frames.metrics()
        for topic, (n, dropped) in self.samples.items():
            out[f"{topic}_samples"] = n
            out[f"{topic}_samples_dropped"] = dropped
        return {"faults": out}
