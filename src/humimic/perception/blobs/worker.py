"""Run a :class:`~humimic.perception.blobs.core.PerceptionCore` in a separate process.

Threads share one interpreter lock: perception in a worker *thread* slows the simulation's
own Python work (the mimic stage, the physics loop) about twofold. A worker *process* does not.

Protocol (one child per run, one frame in flight, FIFO, so results are those of the
synchronous path):

* the child is started with ``python -m humimic.perception.blobs.worker`` (no re-import of the
  caller's ``__main__``, unlike ``multiprocessing``'s spawn) and imports only perception code;
  it says ``ready`` when it can work. Start-up (~0.1-0.3 s) never blocks the simulation: the
  stage keeps processing in a thread until :meth:`ProcessWorker.ready` and then hands its core
  over (:meth:`ProcessWorker.adopt`: the core pickled, random generators and all, so the child
  carries on exactly where the thread stopped);
* per frame the images are copied into a shared memory block (an anonymous ``memfd``, or an
  unlinked temporary file, handed to the child at start) and only the frame's time and camera
  models go through the pipe; the child answers with the
  :class:`~humimic.perception.blobs.core.FrameResult` and its compute time;
* closing the pipe ends the child; an error in the child is raised in the caller.

Why not ``concurrent.futures.ProcessPoolExecutor``: ``fork`` would copy a process that holds an
EGL context and MuJoCo's threads, ``spawn``/``forkserver`` re-import the caller's ``__main__``
(``humimic.run`` brings rerun and matplotlib: seconds, not 0.1 s), and its pickled arguments go
through a pipe - two 320x240 images cost ~0.8 ms of the simulation thread per frame that way,
~0.05 ms through shared memory.
"""

from __future__ import annotations

import mmap
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from multiprocessing.connection import Connection
from pathlib import Path

import numpy as np


def _shared_file() -> int:
    """A file descriptor of an anonymous file for shared memory (never on disk if possible)."""
    if hasattr(os, "memfd_create"):
        return os.memfd_create("humimic-perception", 0)
    shm = "/dev/shm" if os.path.isdir("/dev/shm") else None
    fd, path = tempfile.mkstemp(prefix="humimic-perception-", dir=shm)
    os.unlink(path)
    return fd


class ProcessWorker:
    """The caller's side: start the child, hand it the core, submit frames, collect results."""

    def __init__(self) -> None:
        self._shm_fd = _shared_file()
        r_in, w_in = os.pipe()  # caller -> child
        r_out, w_out = os.pipe()  # child -> caller
        # the child imports the humimic the caller runs (whatever put it on sys.path)
        root = str(Path(__file__).resolve().parents[2])
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [root, *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))])}
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "humimic.perception.blobs.worker", str(r_in), str(w_out),
                 str(self._shm_fd)],
                pass_fds=(r_in, w_out, self._shm_fd), stdin=subprocess.DEVNULL,
                close_fds=True, env=env)
        except BaseException:
            for fd in (r_in, w_in, r_out, w_out, self._shm_fd):
                os.close(fd)
            raise
        os.close(r_in)
        os.close(w_out)
        self._send = Connection(w_in, readable=False)
        self._recv = Connection(r_out, writable=False)
        self._ready = False
        self._map: mmap.mmap | None = None
        self._layout: list[tuple[str, tuple, str, int]] = []
        self.startup_s: float | None = None
        self._t_start = time.perf_counter()

    # ---- start-up ----------------------------------------------------------------------------
    def ready(self) -> bool:
        """Whether the child has started (never blocks)."""
        if not self._ready and self._recv.poll():
            self._expect("ready")
            self._ready = True
            self.startup_s = time.perf_counter() - self._t_start
        return self._ready

    def adopt(self, core) -> None:
        """Hand ``core`` (in its current state) to the child; use the child from now on."""
        if not self.ready():
            self._expect("ready")
            self._ready = True
        self._send.send_bytes(pickle.dumps(("core", core), pickle.HIGHEST_PROTOCOL))

    # ---- frames ------------------------------------------------------------------------------
    def submit(self, t: float, images: dict) -> None:
        """Start processing one frame (``{camera: CameraImage}``) in the child."""
        layout, size = [], 0
        for name, img in images.items():
            a = img.image
            layout.append((name, a.shape, a.dtype.str, size))
            size += a.nbytes
        if self._map is None or size > len(self._map) or layout != self._layout:
            if self._map is None or size > len(self._map):
                if self._map is not None:
                    self._map.close()
                os.ftruncate(self._shm_fd, max(size, 1))
                self._map = mmap.mmap(self._shm_fd, max(size, 1))
            self._layout = layout
        buf = self._map
        for (_, shape, dtype, offset), img in zip(layout, images.values(), strict=True):
            np.copyto(np.ndarray(shape, dtype, buf, offset), img.image, casting="no")
        cams = {name: img.camera for name, img in images.items()}
        self._send.send_bytes(pickle.dumps(("frame", t, cams, layout, size),
                                           pickle.HIGHEST_PROTOCOL))

    def result(self):
        """The submitted frame's ``(FrameResult, compute seconds)`` (blocks)."""
        return self._expect("result")

    def _expect(self, kind: str):
        try:
            msg = pickle.loads(self._recv.recv_bytes())
        except EOFError:
            code = self.proc.wait(timeout=5)
            raise RuntimeError(f"the perception worker process ended (exit status {code})"
                               ) from None
        if msg[0] == "error":
            raise RuntimeError(f"the perception worker process failed:\n{msg[1]}")
        if msg[0] != kind:
            raise RuntimeError(f"perception worker: expected {kind!r}, got {msg[0]!r}")
        return msg[1] if len(msg) == 2 else msg[1:]

    def close(self) -> None:
        """End the child (closing the pipe ends its loop) and free the shared memory."""
        for conn in (self._send, self._recv):
            conn.close()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self._map is not None:
            self._map.close()
            self._map = None
        os.close(self._shm_fd)


# ---- the child ---------------------------------------------------------------------------------
def _serve(recv: Connection, send: Connection, shm_fd: int) -> None:
    import humimic.perception.blobs.core  # noqa: F401  (imports everything a core unpickles)
    from humimic.perception.cues.color_models import load_posterior_kernels
    from humimic.sensors.camera_model import CameraImage

    load_posterior_kernels()   # numba's, loaded here too: a core unpickled does not load them

    try:
        send.send_bytes(pickle.dumps(("ready",)))
    except OSError:  # the caller stopped during its set-up (e.g. a scenario error): nothing to do
        return
    core, buf = None, None
    while True:
        try:
            msg = pickle.loads(recv.recv_bytes())
        except EOFError:
            return
        try:
            if msg[0] == "core":
                core = msg[1]
                continue
            _, t, cams, layout, size = msg
            if buf is None or len(buf) < size:
                buf = mmap.mmap(shm_fd, size)
            images = {name: CameraImage(t, cams[name],
                                        np.ndarray(shape, dtype, buf, offset).copy())
                      for name, shape, dtype, offset in layout}
            t0 = time.perf_counter()
            out = core.process(t, images)
            reply = ("result", out, time.perf_counter() - t0)
        except Exception:  # reported to the caller, which raises
            reply = ("error", traceback.format_exc())
        try:
            send.send_bytes(pickle.dumps(reply, pickle.HIGHEST_PROTOCOL))
        except OSError:  # the caller closed the pipe (run over): nobody needs the result
            return


def main(argv: list[str]) -> int:
    # Ctrl-C reaches the whole process group: the caller stops its loop cleanly and still
    # collects the frame in flight, so the child must outlive it (it ends when the pipe closes)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    r, w, shm_fd = (int(a) for a in argv)
    _serve(Connection(r, writable=False), Connection(w, readable=False), shm_fd)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
