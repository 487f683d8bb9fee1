"""Warm-ups load every compiled kernel a stage's frames call: after the 2-D hand tracker's
:func:`~humimic.perception.trackers.hand2d.warmup.load_kernels`, tracking synthetic frames adds
no numba specialisation; after the shared cue warm-up
(:func:`~humimic.perception.trackers.frame_cues.load_kernels`, ICU, TBP, GEST) the skin
posterior of an image and of a strided view (ICU's) and the moving edges add none. Each run in
a fresh interpreter: in this one other tests have compiled them already, and the check could
not fail."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

_COUNTS = textwrap.dedent("""
    import sys
    import cv2, numba, numpy as np
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model

    def counts():
        out = {}
        for name, mod in list(sys.modules.items()):
            if name.startswith("humimic"):
                for v in vars(mod).values():
                    if isinstance(v, numba.core.registry.CPUDispatcher):
                        out[v.py_func.__module__ + "." + v.__name__] = len(v.signatures)
        return out
""")

_HAND2D = _COUNTS + textwrap.dedent("""
    from humimic.perception.trackers.hand2d.config import Hand2DConfig
    from humimic.perception.trackers.hand2d.tracker import Hand2DTracker
    from humimic.perception.trackers.hand2d.warmup import load_kernels

    cfg = Hand2DConfig(kind="hand2d", rho=5.0, **{kw})
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    load_kernels(cfg, lut)
    before = counts()
    rng = np.random.default_rng(2)
    tr = Hand2DTracker(cfg, lut, 320, 240, np.random.default_rng(3), faces=None)
    states = []
    for k in range(6):      # a checker wall, a skin ellipse moving right
        yy, xx = np.mgrid[0:240, 0:320]
        img = np.repeat(np.where(((xx // 12 + yy // 12) % 2)[..., None] == 0, 40, 190), 3, 2)
        img = img.astype(np.uint8)
        cv2.ellipse(img, (120 + 3 * k, 120), (15, 27), 0.0, 0, 360, (162, 125, 102), -1)
        img = np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)
        states.append(tr.step(img).state)
    assert states[-1] == "tracking", states
    after = counts()
    print(sorted(k for k in after if after[k] > before.get(k, 0)))
""")


@pytest.mark.parametrize("kw", [{}, {"filter": "icondensation"},
                                {"cues": ("shape", "motion", "skin", "colour"),
                                 "similarity": "dt"}])
def test_warmup_loads_every_kernel_a_frame_calls(kw):
    out = subprocess.run([sys.executable, "-c", _HAND2D.replace("{kw}", repr(kw))],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"


_CUES = _COUNTS + textwrap.dedent("""
    from humimic.perception.cues.motion import OpticalFlow, moving_edges
    from humimic.perception.trackers.frame_cues import load_kernels

    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    load_kernels(lut, 8)
    before = counts()
    img = np.random.default_rng(0).integers(0, 256, (48, 64, 3), np.uint8)
    lut.posterior(img)
    lut.posterior(img[::2, ::2])                      # ICU's skin search
    flow = OpticalFlow()(img, np.roll(img, 1, axis=1))
    moving_edges(np.ascontiguousarray(img[..., 0]), flow)
    after = counts()
    print(sorted(k for k in after if after[k] > before.get(k, 0)))
""")


def test_cue_warmup_loads_the_posterior_and_moving_edges():
    out = subprocess.run([sys.executable, "-c", _CUES], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"


_POSTERIOR = _COUNTS + textwrap.dedent("""
    from humimic.perception.cues.color_models import load_posterior_kernels

    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))
    load_posterior_kernels()
    before = counts()
    img = np.random.default_rng(0).integers(0, 256, (48, 64, 3), np.uint8)
    lut.posterior(img)
    lut.posterior(img[10:30, 5:40])                   # zncc's colour-masked crop
    after = counts()
    print(sorted(k for k in after if after[k] > before.get(k, 0)))
""")


def test_posterior_warmup_covers_images_and_crops():
    """Ude's perception core (stereo ``color_mask``) and its worker process load the
    posterior's kernel with :func:`load_posterior_kernels`."""
    out = subprocess.run([sys.executable, "-c", _POSTERIOR], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"
