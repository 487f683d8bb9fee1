"""The perception stage: both eye images -> named 3-D measurements in the robot base frame.

The per-frame work (tracking, identities, stereo, triangulation; Ude eqs. 1-10) is
:class:`~humimic.perception.blobs.core.PerceptionCore`'s; this stage feeds it the ``frames`` topic,
publishes ``measurements`` with the frame's photon time, ready ``latency`` after the frame was
(a declared processing delay; the compute time itself is reported separately in
``stages.perception``), records every frame and logs blobs and state changes to rerun. A frame
set in which a camera repeats its previous image bit for bit (frozen, see
:mod:`humimic.sensors.faults`) is skipped like a lost one when the cameras have pixel noise.

Pipelining (``perception.pipelined``): when the declared latency is at least one camera frame,
each frame is processed in a worker while the simulation goes on, and the result is collected
when the next frame arrives -- never later than its declared ready time, so what is published,
and when (simulated time), is the same as without the worker. ``stages.perception`` is then the
worker's compute time, ``stages.perception_wait`` what the loop waited for it. The worker is

* ``process``: a child process (:mod:`humimic.perception.blobs.worker`); no lock is shared with the
  simulation, whose own Python work (mimic, physics loop) would otherwise run about half as
  fast. Until the child has started (0.1-0.3 s) frames are processed in a thread, then the
  core is handed over;
* ``thread``: a worker thread (MuJoCo renders without holding the interpreter lock, but the
  rest of the loop contends with perception for it);
* ``auto`` (default, also ``true``): ``process`` for runs of at least :data:`PROCESS_MIN_S`
  simulated seconds on a machine with two or more cores, else ``thread``;
* ``off`` (also ``false``): synchronous, in the simulation loop.

Results are identical in every mode (tested).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from humimic.perception.blobs.core import FrameResult, PerceptionCore
from humimic.perception.blobs.record import PerceptionRecord
from humimic.perception.cues.auto_colors import look_alike_report
from humimic.pipeline.stage import Stage
from humimic.sensors.faults import RepeatDetector
from humimic.viz.rerun_log import EVENTS, OTHER_COLOR, TARGET_COLORS, image_entity

#: ``auto`` runs perception in a process for runs at least this long (simulated s). The child
#: starts in ~0.2 s (of CPU on the other core, while frames go to the thread); measured on 2
#: cores, closed loop (mimic_tracked_wave): process / thread / synchronous 2.0 / 2.4 / 2.6x real
#: time for 0.5 s runs, 2.6 / 2.4 / 2.5x for 1 s, 3.1 / 2.2 / 2.4x for 2 s, 3.3 / 2.2 / 2.5x for
#: 4 s; perception alone (ude_wave_tracking, pixel noise) favours the thread (4 s: 3.4 / 3.7x,
#: without noise 4.3 / 3.5x).
PROCESS_MIN_S = 2.0


def usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def worker_kind(mode: str, duration: float) -> str:
    """``process``, ``thread`` or ``none`` for a configured ``perception.pipelined`` mode."""
    if mode == "auto":
        return "process" if duration >= PROCESS_MIN_S and usable_cpus() >= 2 else "thread"
    return {"off": "none"}.get(mode, mode)


class PerceptionStage(Stage):
    """See the module docstring; ``luts`` as :class:`~humimic.perception.blobs.core.PerceptionCore`.
    ``duration`` (simulated s) is the run's length, for the ``auto`` worker choice."""

    name = "perception"

    def __init__(self, cfg, cameras: tuple[str, str], luts: dict, rng: np.random.Generator,
                 record: PerceptionRecord, rlog=None, latency: float = 0.0,
                 frame_period: float = np.inf, duration: float = np.inf,
                 skip_repeats: bool = False):
        self.core: PerceptionCore | None = PerceptionCore(cfg, cameras, luts, rng)
        ratios = [lut.look_alike for lut in luts.values() if lut.look_alike is not None]
        self.look_alike = max(ratios) if ratios else None
        """The learned skin model's look-alike pixels per skin pixel (None: from a file)."""
        lost = [lut.class_lost for lut in luts.values() if lut.class_lost is not None]
        self.skin_lost = max(lost) if lost else None
        """The share of the skin's own pixels the learned table lost (None: from a file)."""
        self.repeats = RepeatDetector(skip_repeats)
        """Frozen frames (a camera repeating its image) are skipped like lost ones."""
        self.cameras, self.rlog = self.core.cameras, rlog
        self.published, self.targets = self.core.published, self.core.targets
        self.latency = float(latency)
        """Declared processing latency (s)."""
        self.pipelined = cfg.pipelined != "off" and self.latency >= frame_period - 1e-9
        self.worker = worker_kind(cfg.pipelined, duration) if self.pipelined else "none"
        self._pool = ThreadPoolExecutor(1, "perception") if self.pipelined else None
        self._proc = None
        if self.worker == "process":
            from humimic.perception.blobs.worker import ProcessWorker

            try:
                self._proc = ProcessWorker()
            except (OSError, ValueError):  # no such child process here: the thread does it
                self.worker = "thread"
        self._pending = None
        self._events: list[tuple[float, str, str, str]] = []
        self._viz = None
        self.record = record
        self.identity_solves = 0
        self.facing_turns = 0
        self._bus = self._timer = None

    # ---- pipeline ----------------------------------------------------------------------------
    def attach(self, bus, timer) -> None:
        self._bus, self._timer = bus, timer
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic: str, msg) -> None:
        stale = self.repeats.stale(msg.value)
        if self._pool is None:
            if not stale:
                with self._timer.time(self.name):
                    out = self.core.process(msg.t, msg.value)
                self._publish(msg, out)
            return
        self.flush()  # the previous frame: due no later than now (latency >= one frame)
        if stale:
            return
        if self.core is not None and self._proc is not None and self._proc.ready():
            t0 = time.perf_counter()
            self._proc.adopt(self.core)  # the child carries on from this state
            self.core = None
            self._timer.add("perception_wait", time.perf_counter() - t0, calls=0)
        if self.core is None:
            self._proc.submit(msg.t, msg.value)
            self._pending = (msg, None)
        else:
            self._pending = (msg, self._pool.submit(self._timed_process, msg.t, msg.value))

    def servo(self, t: float, bus) -> None:
        """Publish a pipelined result that no frame came to collect by its ready time (the next
        frame was lost), and deliver it now, as it would have been."""
        if self._pending is not None and t + 1e-9 >= self._pending[0].t_ready + self.latency:
            self.flush()
            bus.deliver(t)

    def _timed_process(self, t: float, images: dict):
        t0 = time.perf_counter()
        out = self.core.process(t, images)
        return out, time.perf_counter() - t0

    def flush(self) -> None:
        """Collect the frame being processed in the worker (if any) and publish it."""
        if self._pending is None:
            return
        msg, future = self._pending
        self._pending = None
        with self._timer.time("perception_wait"):
            out, seconds = future.result() if future is not None else self._proc.result()
        self._timer.add(self.name, seconds)
        self._publish(msg, out)

    def process(self, t: float, images: dict):
        """Process and record one stereo frame (``{camera: CameraImage}``) now, outside the
        pipeline: its :class:`~humimic.messages.Measurements` (not published)."""
        if self.core is not None:
            out = self.core.process(t, images)
        else:
            self._proc.submit(t, images)
            out, _ = self._proc.result()
        self._record(out)
        return out.measurements

    def _record(self, out: FrameResult) -> None:
        if self.record.intrinsics is None:
            self.record.intrinsics = out.intrinsics
        self.record.append(*out.record_row)
        self.identity_solves = out.identity_solves
        self.facing_turns = out.facing_turns
        self._events += [(t, f"{EVENTS}/perception/{name}", text, level)
                         for t, name, text, level in out.events]
        self._viz = out.viz

    def _publish(self, msg, out: FrameResult) -> None:
        self._record(out)
        self._bus.publish("measurements", msg.then(out.measurements, self.latency))
        if self.rlog is not None and self.rlog.enabled:
            with self._timer.time("perception_viz"):
                self._log()

    def _log(self) -> None:
        """The last processed frame's blobs (both images) and state changes, to rerun."""
        for event in self._events:
            self.rlog.log_text(*event)
        self._events.clear()
        t, seen, centre, cov = self._viz
        for eye, cam in enumerate(self.cameras):
            idx = np.flatnonzero(seen[:, eye])
            self.rlog.log_ellipses_2d(
                t, image_entity(cam) + "/blobs", centre[idx, eye], cov[idx, eye],
                colors=[TARGET_COLORS.get(self.targets[i], OTHER_COLOR) for i in idx],
                labels=[self.targets[i] for i in idx])

    # ---- results -----------------------------------------------------------------------------
    def finish(self) -> None:
        self.flush()  # the last frame (after the loop: published to nobody, but recorded)

    def metrics(self) -> dict:
        out = {"targets": self.published, "distractors": self.targets[len(self.published):],
               "cameras": list(self.cameras), "frames": len(self.record),
               "identity_solves": self.identity_solves, "facing_turns": self.facing_turns,
               "latency_ms": 1e3 * self.latency,
               "pipelined": self.pipelined, "worker": self.worker,
               "stale_frames_skipped": self.repeats.stale_frames,
               **look_alike_report(self.look_alike, self.skin_lost)}
        return {"perception": out}

    def close(self) -> None:
        self._pending = None
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        if self._proc is not None:
            self._proc.close()
            self._proc = None
