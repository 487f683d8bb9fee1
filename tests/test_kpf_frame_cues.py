"""Cue maps computed only where the particles look (``FrameCues``): the likelihood of particle
sets spread over the image, near its borders and partly off it, is the same as with the whole
frame's maps (a region's maps equal the whole image's inside its margin, to float32 rounding;
a sample read outside the region would be off by the cue's whole value)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic import bodymodel as bm
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.cues import cue_maps
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics

INTR = Intrinsics(320, 240, 260.0, 260.0, 159.5, 119.5)
#: Camera at the base origin looking along its +x (base frame: x forward, z up).
T_CAM_BASE = np.array([[0.0, -1, 0, 0], [0, 0, -1, 0.1], [1, 0, 0, 0], [0, 0, 0, 1]])


def test_region_maps_give_the_whole_frame_likelihood():
    rng = np.random.default_rng(7)
    img = cv2.GaussianBlur(rng.integers(0, 255, (240, 320, 3)).astype(np.uint8), (0, 0), 1.5)
    cv2.rectangle(img, (120, 60), (200, 200), (190, 140, 120), -1)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    body = kpf_body()
    cfg = KpfConfig()
    q0 = np.zeros(14)
    q0[0], q0[3] = 2.0, np.pi                                     # 2 m away, facing the camera
    q0[[6, 10]] = 0.3
    whole = Likelihood(body, INTR, cfg)
    part = Likelihood(body, INTR, cfg)
    full = cue_maps(img, lut)
    ref = {p: c[0] for p, c in whole.evaluate(q0[None], full, T_CAM_BASE).colours.items()}
    whole.adapt(ref)
    part.adapt(ref)
    D = np.array(cfg.D())
    for spread, shift in ((1.0, 0.0), (3.0, 0.0), (1.0, 0.6), (1.0, -0.9)):
        q = body.free_limits.clamp(q0 + rng.uniform(-spread, spread, (60, 14)) * D)
        q[:, 1] += shift                                         # towards / over an image side
        frame = FrameCues(img, lut)
        a = whole.evaluate(q, full, T_CAM_BASE)
        b = part.evaluate(q, frame, T_CAM_BASE)
        u0, v0, u1, v1 = frame.region
        assert frame.maps.rgb.shape[:2] == (v1 - v0, u1 - u0)
        for c in a.cost:   # float32 filters: SIMD rounding differs with the row alignment
            np.testing.assert_allclose(a.cost[c], b.cost[c], rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(a.terms, b.terms, rtol=1e-5, atol=1e-5)
    assert (u1 - u0) * (v1 - v0) < 320 * 240                     # only part of the frame
    view = bm.project(body, body.forward(q0[None]), INTR, T_CAM_BASE)
    assert np.isfinite(view.sides_uv).all()


@pytest.mark.parametrize("colour", [False, True], ids=["grey", "colour_gradients"])
def test_region_maps_equal_the_whole_image_maps_inside_the_margin(colour):
    """A region's gradient, ridge (every pyramid level) and colour maps against the whole
    image's, at every pixel at least ``MARGIN_PX`` inside the region's inner edges: equal (to
    float32 rounding); the level-2 ridge map differs nearer than that (the margin is needed).
    The same with the derivatives of the strongest colour channel."""
    from humimic.perception.trackers.kpf.frame_cues import MARGIN_PX

    rng = np.random.default_rng(3)
    img = cv2.GaussianBlur(rng.integers(0, 255, (240, 320, 3)).astype(np.uint8), (0, 0), 3.0)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    full = cue_maps(img, lut, colour_gradients=colour)
    u0, v0, u1, v1 = 64, 40, 200, 184
    part = cue_maps(img, lut, region=(u0, v0, u1, v1), colour_gradients=colour)
    m = MARGIN_PX
    np.testing.assert_allclose(part.gradient[m:-m, m:-m],
                               full.gradient[v0 + m:v1 - m, u0 + m:u1 - m], atol=1e-6)
    np.testing.assert_array_equal(part.rgb, full.rgb[v0:v1, u0:u1])
    near = []
    for mu, ((h, w), r, rf) in enumerate(zip(part.level_shapes, part.level_rows,
                                            full.level_rows, strict=True)):
        k = 2 ** mu
        a = part.ridge[r:r + h, :w]
        b = full.ridge[rf + v0 // k:rf + v0 // k + h, u0 // k:u0 // k + w]
        i = int(np.ceil(m / k))
        np.testing.assert_allclose(a[i:-i, i:-i], b[i:-i, i:-i], atol=1e-5)
        near.append(np.abs(a[1:-1, 1:-1] - b[1:-1, 1:-1]).max())
    assert near[2] > 1e-3                            # inside 1 level-2 pixel: edge effects


def test_sample_box_ignores_invalid_parts():
    """NaN (invalid parts) and infinite (degenerate conics) coordinates do not widen or void
    the box: it still bounds every finite sample point."""
    from humimic.perception.trackers.kpf.frame_cues import sample_box

    body = kpf_body()
    q = np.zeros((3, 14))
    q[:, 0], q[:, 3] = 2.0, np.pi
    view = bm.project(body, body.forward(q), INTR, T_CAM_BASE)
    centre, axes, angle = view.ellipses_px()
    lo, hi = sample_box(view, (centre, axes, angle))
    bad = centre.copy()
    bad[0, 0] = np.inf
    bad[1, 1] = np.nan
    lo2, hi2 = sample_box(view, (bad, axes, angle))
    assert np.all(np.isfinite(lo2)) and np.all(lo2 >= lo - 1e-9) and np.all(hi2 <= hi + 1e-9)
    assert np.all(hi2 - lo2 > 20.0)                        # the other parts still bound it
    assert np.all(view.sides_uv[np.isfinite(view.sides_uv)].reshape(-1) >= min(lo2) - 1e-9)
