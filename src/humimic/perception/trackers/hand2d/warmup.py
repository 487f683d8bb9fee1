"""Load the 2-D hand tracker's compiled kernels before its first timed frame.

numba compiles a kernel on its first call, or loads it from the on-disk cache: left to the
first frames, that time lands in the tracker's per-frame timing and stalls the perception loop
once (menezes_fig5_hand, warm cache: the first two frames 36 and 35 ms CPU against ~4.5 ms for
the next; the skin posterior, ROI bounds, moving edges, edge codes, normal search, rim probes
and template kernels were loaded there, after the colour-count warm-up). :func:`load_kernels`
runs a throwaway tracker of the same configuration (its own generator: the run's random stream
is not touched) through a detection frame and a tracking frame of a small synthetic image, so
every specialisation the real tracker calls is loaded.
"""

from __future__ import annotations

import numpy as np

from humimic.perception.trackers.hand2d.tracker import Hand2DTracker

_W, _H = 320, 64


def load_kernels(cfg, lut) -> None:
    """Step a throwaway :class:`Hand2DTracker` (``cfg``, skin ``lut``) once searching and once
    tracking, on a grey image with a skin-coloured square (module docstring)."""
    tracker = Hand2DTracker(cfg, lut, _W, _H, np.random.default_rng(0), faces=None)
    image = np.full((_H, _W, 3), 128, np.uint8)
    image[24:40, 32:48] = (200, 150, 120)
    tracker.step(image)                               # a detection frame
    tracker.start(np.array([40.0, 32.0, 16.0, 0.1]), image)
    tracker.step(image)                               # a tracking frame (flow from the first)


__all__ = ["load_kernels"]
