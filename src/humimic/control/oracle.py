"""Oracle perception: the true state of the targets, optionally noisy and late, published on
``estimates`` at the camera rate - the same messages the tracked pipeline (blob tracker, stereo,
random-jerk Kalman filter) publishes. Running mimicry on it separates control error from
perception error.

For every eye-camera frame (photon time ``t``) the oracle reads the ground truth at ``t``
(robot base frame), adds white Gaussian noise to p, v and a when asked, and makes the estimate
available at ``t_ready(frame) + latency``. With ``require_in_view`` a target is reported only
while it projects inside every eye camera's image (as a tracker could see it); a target never
seen is never reported, and mimicry says so in its metrics.

Sensor faults (:mod:`humimic.sensors.faults`) reach the oracle as they reach a tracker: a lost
frame gives no estimate, a covered camera sees nothing (no estimate for that frame), and a frozen
camera shows the past, so the estimate is the truth at the oldest capture time among the frame's
images (stale, under the new time stamp).
"""

from __future__ import annotations

import numpy as np

from humimic.control.gaze import camera_frame_point
from humimic.messages import Estimates, TargetEstimate
from humimic.pipeline.stage import Stage
from humimic.stamped import Stamped


def in_image(p_cam: np.ndarray, intrinsics) -> bool:
    """Whether a camera-frame point (OpenCV axes) projects inside the image."""
    return bool(p_cam[2] > 1e-6 and intrinsics.contains(intrinsics.project(p_cam)))


def noisy_state(p: np.ndarray, v: np.ndarray, a: np.ndarray, std: tuple[float, float, float],
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(p, v, a)`` plus independent white Gaussian noise of standard deviations ``std``."""
    out = []
    for x, s in zip((p, v, a), std, strict=True):
        out.append(x + rng.normal(0.0, s, 3) if s > 0.0 else x.copy())
    return out[0], out[1], out[2]


def oracle_covariance(std: tuple[float, float, float]) -> np.ndarray | None:
    """``(9, 9)`` diagonal covariance of the oracle's (p, v, a) noise (None if noise-free)."""
    if not any(std):
        return None
    return np.diag(np.repeat(np.square(std), 3))


class OracleStage(Stage):
    """Publishes ``estimates`` of ``targets`` from ground truth for each camera frame."""

    name = "oracle"

    def __init__(self, world, targets: list[str], cfg, rng: np.random.Generator):
        self.world, self.cfg, self.rng = world, cfg, rng
        self.targets = list(targets)
        gt = world.gt
        self._p = {k: gt.p_base(k) for k in self.targets}
        self._v = {k: gt.v_base(k) for k in self.targets}
        self._a = {k: gt.a_base(k) for k in self.targets}
        self._world_p = {k: gt.p_world(k) for k in self.targets}
        self.rate = world.scenario.timing.physics_rate
        self.std = (cfg.noise_std, cfg.velocity_noise_std, cfg.acceleration_noise_std)
        self.P = oracle_covariance(self.std)
        scene = world.scene
        self._cams = [(scene.camera(n), world.eye_rig.intrinsics(n)) for n in world.eye_cameras]
        self.published = dict.fromkeys(self.targets, 0)
        self.out_of_view = dict.fromkeys(self.targets, 0)
        self.frames = 0
        self.blind_frames = 0
        self.stale_frames = 0
        self._bus = None
        self._timer = None

    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("frames", self._on_frame)

    def visible(self, p_world: np.ndarray) -> bool:
        data = self.world.scene.data
        return all(in_image(camera_frame_point(data, cid, p_world), intr)
                   for cid, intr in self._cams)

    def _content_time(self, t: float, cameras) -> float | None:
        """Capture time of what the frame at ``t`` shows (None if a camera is covered)."""
        t_content = t
        for name in cameras:
            status = self.world.faults.frames.status(t, name)
            if status is not None:
                if status.covered:
                    return None
                t_content = min(t_content, status.t_content)
        return t_content

    def _on_frame(self, topic: str, msg: Stamped) -> None:
        with self._timer.time(self.name):
            self.frames += 1
            t_content = self._content_time(msg.t, msg.value)
            if t_content is None:
                self.blind_frames += 1
                out = {}
            else:
                self.stale_frames += t_content < msg.t
                out = self._estimates(t_content)
            self._bus.publish("estimates", Stamped(msg.t, Estimates(out),
                                                   msg.t_ready + self.cfg.latency))

    def _estimates(self, t: float) -> dict[str, TargetEstimate]:
        """The (noisy) truth of every target in view at time ``t``."""
        k = min(int(round(t * self.rate)), len(self.world.times) - 1)
        out = {}
        for target in self.targets:
            if self.cfg.require_in_view and not self.visible(self._world_p[target][k]):
                self.out_of_view[target] += 1
                continue
            p, v, a = noisy_state(self._p[target][k], self._v[target][k], self._a[target][k],
                                  self.std, self.rng)
            out[target] = TargetEstimate(target, p, v, a, self.P)
            self.published[target] += 1
        return out

    def metrics(self) -> dict:
        return {"oracle": {"frames": self.frames, "estimates": dict(self.published),
                           "out_of_view_frames": dict(self.out_of_view),
                           "blind_frames": self.blind_frames, "stale_frames": self.stale_frames,
                           "latency_ms": 1e3 * self.cfg.latency,
                           "noise_std_mm": 1e3 * self.cfg.noise_std}}
