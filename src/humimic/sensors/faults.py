"""Sensor faults, injected into what the sensors publish: lost, frozen and covered camera frames
and lost inertial samples. Seeded from the scenario's :class:`~humimic.rngs.Rngs`.

The sensors render and sample as if nothing were wrong; the faults act on the published values,
as a transfer link or a lens cover would:

* ``cameras.drop_rate``: a stereo frame set is lost in transfer with this probability (the
  capture is synchronised, so both images go). Nothing is published: downstream stages see a
  gap in the frame times, and the filter predicts across it at the next frame.
* ``cameras.freeze_rate``: with this probability, per camera and frame, a camera delivers the
  image it delivered last again (stale pixels under a new time stamp, as a frame grabber that
  missed a buffer swap does), with the eyes' current pose.
* ``cameras.covered``: a camera's image is black during a time window (a hand over the lens),
  bar the camera's own pixel noise (a sensor's dark noise; the negative half clips at 0).
* ``sensors.imu.drop_rate`` / ``sensors.wiimote.drop_rate``: an inertial sample is lost.

A receiver can tell a frozen frame when the camera has pixel noise: a fresh noisy image never
repeats its predecessor bit for bit (:class:`RepeatDetector`; perception then skips the frame
set as if it were lost). Without noise a still scene repeats legitimately and nothing is flagged.

Every frame draws the same random numbers whatever happens to it (one for the drop, one per
camera for the freeze), so one fault's rate never shifts another's pattern. The counts seen are
reported under ``faults`` (``frames_dropped``; ``frames_frozen`` and ``frames_covered`` among
the frames delivered; ``<sensor>_samples_dropped``); :meth:`FrameFaults.status` tells
ground-truth stages (the oracle) what happened to a frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.scenario.errors import ScenarioError
from humimic.sensors.camera_model import CameraImage
from humimic.world.names import EYE_CAMERAS

#: Inertial sensors with a ``drop_rate`` (their ``sensors`` key is their bus topic).
INERTIAL = ("imu", "wiimote")


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

    ``covered`` maps a camera name to its black windows ``[(start, end), ...]`` (s);
    ``noise_std`` is the cameras' pixel noise (grey levels), drawn from ``dark_rng`` into a
    covered image (the other faults' draws never depend on it).
    """

    def __init__(self, cameras: list[str], drop_rate: float = 0.0, freeze_rate: float = 0.0,
                 covered: dict[str, list[tuple[float, float]]] | None = None,
                 rng: np.random.Generator | None = None, noise_std: float = 0.0,
                 dark_rng: np.random.Generator | None = None):
        self.cameras = list(cameras)
        self.drop_rate, self.freeze_rate = float(drop_rate), float(freeze_rate)
        self.covered = {c: list(w) for c, w in (covered or {}).items() if w}
        self.rng, self.noise_std, self.dark_rng = rng, float(noise_std), dark_rng
        if (self.drop_rate > 0.0 or self.freeze_rate > 0.0) and rng is None:
            raise ValueError("random faults need a random generator")
        if self.noise_std > 0.0 and self.covered and dark_rng is None:
            raise ValueError("dark noise needs a random generator")
        self._last: dict[str, tuple[np.ndarray, float]] = {}
        self.faulted: dict[float, dict[str, FrameStatus]] = {}
        """Frame time (s) -> the cameras frozen or covered in that frame set."""
        self.frames = 0
        self.lost: list[float] = []
        """Times (s) of the frame sets lost."""
        self.frozen = dict.fromkeys(self.cameras, 0)
        self.blacked = dict.fromkeys(self.cameras, 0)

    @property
    def dropped(self) -> int:
        return len(self.lost)

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
        if u[0] < self.drop_rate:
            self.lost.append(t)
            return None
        out, status = {}, {}
        for i, name in enumerate(self.cameras):
            img = images[name]
            pixels, t_content = img.image, img.t
            frozen = covered = False
            if in_window(t, self.covered.get(name, ())):
                pixels, covered = self._dark(img.image.shape), True
                self.blacked[name] += 1
            elif u[1 + i] < self.freeze_rate and name in self._last:
                (pixels, t_content), frozen = self._last[name], True
                self.frozen[name] += 1
            self._last[name] = (pixels, t_content)
            out[name] = img if pixels is img.image else CameraImage(img.t, img.camera, pixels)
            if frozen or covered:
                status[name] = FrameStatus(frozen, covered, t_content)
        if status:
            self.faulted[t] = status
        return out

    def _dark(self, shape: tuple[int, ...]) -> np.ndarray:
        """A covered camera's image: black plus its pixel noise, clipped at 0."""
        if self.noise_std <= 0.0:
            return np.zeros(shape, np.uint8)
        noise = self.dark_rng.normal(0.0, self.noise_std, shape)
        return np.clip(np.rint(noise), 0, 255).astype(np.uint8)

    def status(self, t: float, camera: str) -> FrameStatus | None:
        """What happened to ``camera``'s frame at time ``t`` (None: delivered as captured)."""
        return self.faulted.get(t, {}).get(camera)

    def metrics(self) -> dict:
        return {"frames": self.frames, "frames_dropped": self.dropped,
                "frames_frozen": dict(self.frozen), "frames_covered": dict(self.blacked)}


class RepeatDetector:
    """Flags a frame set in which a camera repeats its previous image bit for bit (stale), when
    ``enabled`` (the cameras have pixel noise; see the module docstring)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self._prev: dict[str, np.ndarray] = {}
        self.stale_frames = 0

    def stale(self, images: dict[str, CameraImage]) -> bool:
        if not self.enabled:
            return False
        out = any(name in self._prev and np.array_equal(self._prev[name], img.image)
                  for name, img in images.items())
        self._prev = {name: img.image for name, img in images.items()}
        self.stale_frames += out
        return out


class SensorFaults:
    """Every fault a scenario configures: the eye cameras' frames and the inertial samples."""

    def __init__(self, scenario, eye_cameras: list[str], rngs):
        c = scenario.cameras
        covered: dict[str, list[tuple[float, float]]] = {}
        for i, w in enumerate(c.covered):
            eyes = ("left", "right") if w.camera == "both" else (w.camera,)
            kinds = ("wide", "foveal") if c.which == "both" else (c.which,)
            for eye, kind in ((e, k) for e in eyes for k in kinds):
                name = EYE_CAMERAS[(eye, kind)]
                if name not in eye_cameras:
                    raise ScenarioError(f"scenario {scenario.name!r}", f"cameras.covered.{i}."
                                        "camera", f"the {eye} eye's camera is not rendered "
                                        f"(cameras.enabled: {c.enabled}, cameras.eyes: "
                                        f"{c.eyes})", w.camera, "a camera the scenario renders")
                covered.setdefault(name, []).append((w.start, w.end))
        random = c.drop_rate > 0.0 or c.freeze_rate > 0.0
        self.frames = FrameFaults(eye_cameras, c.drop_rate, c.freeze_rate, covered,
                                  rngs["faults.cameras"] if random else None, c.noise_std,
                                  rngs["faults.dark"] if covered else None)
        self._rngs = rngs
        self._drop_rate = {topic: getattr(scenario.sensors, topic).drop_rate
                           for topic in INERTIAL}
        self.samples: dict[str, tuple[int, int]] = {}

    def keep(self, topic: str, n: int) -> np.ndarray:
        """Which of the ``n`` samples of an inertial sensor are published (counted)."""
        rate = self._drop_rate[topic]
        keep = keep_samples(n, rate, self._rngs[f"faults.{topic}"] if rate > 0.0 else None)
        self.samples[topic] = (n, int(n - keep.sum()))
        return keep

    def metrics(self) -> dict:
        out = self.frames.metrics()
        for topic, (n, dropped) in self.samples.items():
            out[f"{topic}_samples"] = n
            out[f"{topic}_samples_dropped"] = dropped
        return {"faults": out}
