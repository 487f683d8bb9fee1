"""Load GEST's compiled kernels (particle filter, skin blobs, cue images) before its first frame.

numba compiles a kernel on its first call, or loads it from the on-disk cache (measured for
all of these: ~0.2 s of CPU with a warm cache, ~5.5 s without one): left to the first frame,
that time lands in the tracker's per-frame timing and stalls the perception loop once.
:func:`load_kernels` calls every kernel, through the functions the tracker calls, on a tiny
synthetic input of the same array types (so the first real frame finds every specialisation
loaded); once per process.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.perception.cues.histograms import quantize
from humimic.perception.trackers import frame_cues
from humimic.perception.trackers.gest.blobs import hand_blobs
from humimic.perception.trackers.gest.ellipsoid import mean_orientation
from humimic.perception.trackers.gest.likelihood import (
    INSCRIBED,
    blob_pair_log_likelihood,
    patch_color_log_likelihood,
    project_views,
    reference_histogram,
    rim_distances,
)
from humimic.perception.trackers.gest.proposal import walk_densities
from humimic.sensors.camera_model import Intrinsics

_warm = False


@dataclass(frozen=True)
class _View:
    """A 16 x 16 camera at the origin with empty cue images (the fields the likelihood
    reads)."""

    intrinsics: Intrinsics
    T_cam_base: np.ndarray
    dt: np.ndarray
    skin: np.ndarray
    qimage: object


def load_kernels(lut, bins: int) -> None:
    """Call every compiled kernel of GEST's step once (module docstring), the blob and cue
    kernels with the skin model ``lut`` and ``bins`` colour bins; later calls return at once."""
    global _warm
    if _warm:
        return
    view = _View(Intrinsics(16, 16, 20.0, 20.0, 7.5, 7.5, -0.05, 0.01), np.eye(4),
                 np.zeros((16, 16), np.float32), np.zeros((16, 16), np.float32),
                 quantize(np.zeros((16, 16, 3), np.uint8), 8))
    states = np.tile([0.0, 0.0, 0.5, 0.1, 0.2, 0.3, 0.05, 0.03, 0.02], (2, 1))
    (proj, _), centres = project_views(states, [view, view], 8, 1)
    rim_distances(proj, view)
    ref = reference_histogram(proj, view)
    patch_color_log_likelihood(view.qimage, proj.patch_state, INSCRIBED, ref[None], 0.1)
    blob_pair_log_likelihood(centres, centres[:1], 1.0, 1e-6)
    lw = np.log(np.full(2, 0.5))
    walk_densities(states, states, lw, np.full(9, 0.01))
    mean_orientation(states[:, 3:6], lw)
    hand_blobs(np.zeros((4, 4, 3), np.uint8), lut)
    frame_cues.load_kernels(lut, bins)
    _warm = True
