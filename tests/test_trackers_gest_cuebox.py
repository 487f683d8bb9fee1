"""GEST's per-frame cue work made cheaper without changing what it computes: the cue box's pad
(``cue_pad_px``) against the distance transform of the whole image, and the skin LUT's integer
paths against the float posterior."""

from __future__ import annotations

import numpy as np
from _synth_vision import SKIN_RGB, clutter_background

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.cues.edges import DT_CAP_PX, colour_canny, distance_transform
from humimic.perception.trackers.gest.roi import roi_box


def test_a_padded_box_sees_the_whole_images_distances_up_to_the_pad():
    """OpenCV's exact transform of the whole image's edges against the transform of the edges
    in the box padded by ``pad``: equal wherever the whole image's distance is at most
    ``pad`` inside the unpadded box, never smaller elsewhere in it (an edge outside the box
    is not seen)."""
    rng = np.random.default_rng(3)
    edges = colour_canny(clutter_background(rng))
    full = distance_transform(edges)
    inner = (110, 70, 90, 80)                                        # x, y, w, h
    for pad in (10.0, 20.0):
        x0, y0, x1, y1 = roi_box(np.array([inner], float), 320, 240, pad)
        crop = distance_transform(np.ascontiguousarray(edges[y0:y1, x0:x1]))
        a, b = inner[0] - x0, inner[1] - y0
        got = crop[b:b + inner[3], a:a + inner[2]]
        want = full[inner[1]:inner[1] + inner[3], inner[0]:inner[0] + inner[2]]
        near = want <= pad
        assert 0.1 < near.mean() < 0.9                            # both cases occur
        np.testing.assert_allclose(got[near], want[near], atol=1e-4)
        assert (got[~near] >= want[~near] - 1e-4).all() and got.max() <= DT_CAP_PX


def test_skin_lut_index_and_mask_match_the_float_posterior():
    """The int32 index against the channels' bits computed in int64; the uint8 mask
    against ``posterior > threshold``; on a contiguous image and a subsampled view."""
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    rng = np.random.default_rng(0)
    img = clutter_background(rng)
    img[60:120, 90:150] = SKIN_RGB
    img[::7] = rng.integers(0, 256, img[::7].shape, dtype=np.uint8)
    for x in (img, img[1::2, ::2], img[5]):
        q = x.astype(np.int64) >> 2
        want = (q[..., 0] << 12) | (q[..., 1] << 6) | q[..., 2]
        np.testing.assert_array_equal(lut.index(x), want)
        np.testing.assert_array_equal(lut.posterior(x), lut.post_table[want])
        for t in (0.5, 0.8):
            mask = lut.mask(x, t)
            assert mask.dtype == np.uint8
            np.testing.assert_array_equal(mask, lut.post_table[want] > t)
    assert lut.mask(img).any() and not lut.mask(img).all()
