"""GEST's compiled blob kernels (:mod:`humimic.perception.trackers.gest.components`) against
OpenCV: the skin mask's 8-connected components (labels, numbering and stats) equal
``cv2.connectedComponentsWithStats`` on ``ColorLUT.mask`` of the same (sub-sampled) box, and
the per-label counts ``np.bincount``; the fused skin posterior and colour bins of the cue
images equal ``ColorLUT.posterior`` and ``quantize``. The hull moments are checked against
skimage in test_trackers_gest_tracking.py (:func:`hull_moments` calls the kernel)."""

from __future__ import annotations

import cv2
import numpy as np
from _synth_vision import SKIN_RGB
from scipy import ndimage

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.cues.histograms import quantize
from humimic.perception.trackers.frame_cues import skin_and_bins
from humimic.perception.trackers.gest.blobs import hand_blobs
from humimic.perception.trackers.gest.components import count_in_box, skin_components

LUT = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)


def _image(rng: np.random.Generator, h: int, w: int, density: float, smooth: float
           ) -> np.ndarray:
    """Skin where a smoothed random field exceeds its ``density`` quantile (many components
    of every shape), a grey background with colour noise elsewhere."""
    field = ndimage.gaussian_filter(rng.standard_normal((h, w)), smooth) if smooth else \
        rng.standard_normal((h, w))
    skin = field > np.quantile(field, 1.0 - density)
    img = rng.integers(40, 110, (h, w, 3), dtype=np.uint8)
    img[skin] = SKIN_RGB
    return img


def test_skin_components_equal_opencvs_labels_and_stats():
    rng = np.random.default_rng(0)
    parts = 0
    for t in range(40):
        h, w = int(rng.integers(5, 90)), int(rng.integers(5, 90))
        img = _image(rng, h, w, float(rng.uniform(0.2, 0.7)), (0.0, 1.0, 2.5)[t % 3])
        step = int(rng.integers(1, 4))
        y0, x0 = int(rng.integers(0, 4)), int(rng.integers(0, 4))
        y1, x1 = h - int(rng.integers(0, 4)), w - int(rng.integers(0, 4))
        mask = LUT.mask(img[y0:y1:step, x0:x1:step])
        n, want, stats, cent = cv2.connectedComponentsWithStats(mask, connectivity=8)
        labels, got = skin_components(img, y0, y1, x0, x1, step, LUT.mask_table(), LUT.bits)
        parts += n - 1
        np.testing.assert_array_equal(labels, want)
        np.testing.assert_array_equal(got[1:, :5], stats[1:])
        np.testing.assert_array_equal(got[1:, 5:] / got[1:, 4:5], cent[1:])
    assert parts > 300                      # 672: speckled masks, merges of every kind


def test_skin_components_of_an_image_without_skin_and_in_a_box():
    img = np.full((30, 40, 3), 70, np.uint8)
    labels, stats = skin_components(img, 0, 30, 0, 40, 1, LUT.mask_table(), LUT.bits)
    assert not labels.any() and stats.shape == (1, 7)
    img[10:20, 5:9] = SKIN_RGB
    labels, stats = skin_components(img, 5, 30, 2, 40, 1, LUT.mask_table(), LUT.bits)
    np.testing.assert_array_equal(stats[1, :5], [3, 5, 4, 10, 40])       # in the box's pixels


def test_count_in_box_is_bincount():
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 6, (40, 50)).astype(np.int32)
    for y0, y1, x0, x1 in ((0, 40, 0, 50), (5, 17, 30, 49), (-3, 10, 45, 60)):
        want = np.bincount(labels[max(y0, 0):y1, max(x0, 0):x1].ravel(), minlength=6)
        np.testing.assert_array_equal(count_in_box(labels, 5, y0, y1, x0, x1), want)


def test_hand_blobs_in_a_box_are_those_of_the_cropped_image():
    rng = np.random.default_rng(3)
    img = _image(rng, 120, 160, 0.3, 3.0)
    for box in ((0, 0, 160, 120), (13, 7, 150, 101), (40, 30, 90, 80), (100, 70, 230, 200),
                (-20, -9, 60, 50)):                          # the last two: clipped to the image
        x0, y0, x1, y1 = np.clip(box, 0, [160, 120, 160, 120])
        want = hand_blobs(np.ascontiguousarray(img[y0:y1, x0:x1]), LUT, 2)
        got = hand_blobs(img, LUT, 2, box=box)
        assert len(want.areas) > 0
        for a, b in zip((got.centers, got.boxes, got.areas),
                        (want.centers, want.boxes, want.areas), strict=True):
            np.testing.assert_array_equal(a, b)


def test_skin_and_bins_are_the_luts_posterior_and_quantize():
    rng = np.random.default_rng(4)
    for h, w in ((1, 1), (17, 30), (48, 64)):
        img = _image(rng, h, w, 0.4, 1.0) if h > 1 else rng.integers(0, 256, (1, 1, 3), np.uint8)
        for bins in (8, 32):
            skin, planes = skin_and_bins(img, LUT.post_table, LUT.bits, bins)
            np.testing.assert_array_equal(skin, LUT.posterior(img))
            np.testing.assert_array_equal(planes, quantize(img, bins).planes)
