"""Load the kpf tracker's compiled kernels before its first timed frame.

numba compiles a kernel on its first call, or loads it from the on-disk cache (~0.2 s of CPU
with a warm cache, ~7 s without one): left to the first frame, that time would land in the
tracker's per-frame timing (``frames_per_s``) and stall the perception loop once.
:func:`load_kernels` tracks one frame with a throwaway tracker of the same configuration and
its own generator (the run's random stream is not touched), so every specialisation the real
tracker calls is loaded.
"""

from __future__ import annotations

import numpy as np

from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.tracker import KpfTracker


def load_kernels(body, intrinsics, cfg, image: np.ndarray, skin_lut, T_cam_base: np.ndarray,
                 q0: np.ndarray, frame_rate: float | None = None) -> None:
    """Start a throwaway ``KpfTracker`` at ``q0`` on ``image`` and step it once."""
    tracker = KpfTracker(body, intrinsics, cfg, np.random.default_rng(0), frame_rate)
    maps = FrameCues(image, skin_lut, colour_gradients=cfg.colour_gradients)
    tracker.start(q0, maps, T_cam_base)
    tracker.step(maps, T_cam_base)


__all__ = ["load_kernels"]
