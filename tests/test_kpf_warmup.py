""":func:`humimic.perception.trackers.kpf.warmup.load_kernels` leaves nothing for a real
tracker's first frame to compile: after it, stepping a tracker of the same configuration adds
no compiled specialisation to any kernel the step calls."""

from __future__ import annotations

import numpy as np
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

from humimic.bodymodel import forward_kernel, limb_view
from humimic.estimation.particles import kernel
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf import cue_costs, cues, frame_cues
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.tracker import KpfTracker, kpf_body
from humimic.perception.trackers.kpf.warmup import load_kernels


def test_load_kernels_loads_those_a_tracking_step_calls():
    kernels = (limb_view._view_kernel, forward_kernel._forward_kernel,
               cue_costs._costs_kernel, cue_costs._eq10_kernel, frame_cues._box_kernel,
               cues._strongest_mag, cues._edge_planes, cues._ridge_planes,
               kernel._key_runs)
    body, T, q0 = kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cfg = KpfConfig(n_particles=60, iterations=2, colour_gradients=True)  # all kernels
    load_kernels(body, INTRINSICS, cfg, img, lut, T, q0)
    loaded = [len(k.signatures) for k in kernels]
    assert min(loaded) >= 1
    tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(3))
    tr.start(q0, FrameCues(img, lut, colour_gradients=cfg.colour_gradients), T)
    for _ in range(2):
        res = tr.step(FrameCues(img, lut, colour_gradients=cfg.colour_gradients), T)
    assert np.all(np.isfinite(res.mode))
    assert [len(k.signatures) for k in kernels] == loaded
