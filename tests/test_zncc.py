"""ZNCC (Ude eq. 10), the stereo matcher's batched forms, vs cv2.matchTemplate(TM_CCOEFF_NORMED);
the prefiltered image reads."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.perception.blobs.zncc import zncc_strips


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_strips_match_opencv_and_flat_windows_score_zero(dtype):
    rng = np.random.default_rng(1)
    strip = cv2.GaussianBlur(rng.integers(0, 256, (13, 70, 3)).astype(np.uint8), (5, 5), 1.0)
    strip[:, :20] = 77  # a flat area: windows inside it have zero variance
    if dtype == np.float32:
        strip = strip.astype(np.float32) / 255.0
    T = strip[:, 30:43].copy()
    ours = zncc_strips(strip[None], T[None])[0]
    ref = cv2.matchTemplate(strip, T, cv2.TM_CCOEFF_NORMED)[0]
    assert np.all(np.isfinite(ours)) and np.all(ours[:8] == 0.0)
    np.testing.assert_allclose(ours[8:], ref[8:], atol=2e-5)  # cv2: float32, ~1e-6
    assert ours[30] == pytest.approx(1.0, abs=1e-6)
    gain = zncc_strips((3.0 * strip + 0.5)[None].astype(np.float64), T[None])[0]
    np.testing.assert_allclose(gain, ours, atol=1e-6)  # invariant to gain and offset


def test_batched_strips_match_opencv():
    rng = np.random.default_rng(4)
    strips = cv2.GaussianBlur(rng.integers(0, 256, (5 * 13, 70, 3)).astype(np.uint8), (5, 5), 1)
    strips = strips.reshape(5, 13, 70, 3)
    tpls = strips[:, :, 10:23].copy()
    tpls[3] = 90  # a flat template: its row scores 0
    out = zncc_strips(strips, tpls)
    for i in range(5):
        if i == 3:
            assert np.all(out[i] == 0.0)
            continue
        ref = cv2.matchTemplate(strips[i], tpls[i], cv2.TM_CCOEFF_NORMED)[0]
        np.testing.assert_allclose(out[i], ref, atol=2e-5)
        assert int(np.argmax(out[i])) == 10


def test_windows_match_opencv_per_window():
    """zncc_windows (the fine sub-sample search) against cv2.matchTemplate on each window."""
    from humimic.perception.blobs.zncc import zncc_windows

    rng = np.random.default_rng(7)
    n, m, h, w = 3, 5, 9, 11
    img = cv2.GaussianBlur(rng.integers(0, 256, (n * m * h, w, 3)).astype(np.uint8), (5, 5), 1)
    windows = img.reshape(n, m, h, w, 3)
    templates = cv2.GaussianBlur(rng.integers(0, 256, (n * h, w, 3)).astype(np.uint8), (5, 5),
                                 1).reshape(n, h, w, 3)
    templates[1] = windows[1, 3]  # a perfect match
    ours = zncc_windows(windows, templates)
    for i in range(n):
        for j in range(m):
            ref = cv2.matchTemplate(windows[i, j], templates[i], cv2.TM_CCOEFF_NORMED)[0, 0]
            assert ours[i, j] == pytest.approx(ref, abs=2e-5)
    assert ours[1, 3] == pytest.approx(1.0, abs=1e-6)
    flat = np.full((1, 2, h, w, 3), 50, np.uint8)
    assert np.all(zncc_windows(flat, templates[:1]) == 0.0)  # no variance: 0, not NaN


def test_prefiltered_reads_equal_blur_then_remap():
    """Prefiltered blurs only the crop the samples need: same values as blurring the whole
    image (away from its border), and masking multiplies by p / (p + 1) first."""
    from humimic.perception.blobs.zncc import Prefiltered

    rng = np.random.default_rng(8)
    img = rng.integers(0, 256, (120, 160, 3)).astype(np.uint8)
    mx = rng.uniform(40, 110, (6, 20)).astype(np.float32)
    my = rng.uniform(30, 80, (6, 20)).astype(np.float32)
    plain = Prefiltered(img, 0.0).remap(mx, my)
    np.testing.assert_array_equal(plain, cv2.remap(img, mx, my, cv2.INTER_LINEAR,
                                                   borderMode=cv2.BORDER_REPLICATE))
    ours = Prefiltered(img, 0.8).remap(mx, my).astype(float)
    ref = cv2.remap(cv2.GaussianBlur(img, (3, 3), 0.8), mx, my, cv2.INTER_LINEAR).astype(float)
    assert np.abs(ours - ref).max() <= 1.0  # uint8 rounding of bilinear reads
    big = Prefiltered(img, 0.8, spacing=6.0)  # coarse samples: area-reduced by 4, then blurred
    assert big.k == 4 and big.blur == pytest.approx(0.8)
    assert np.abs(big.remap(mx, my).astype(float).mean() - img.mean()) < 3.0

    class Half:  # a colour model giving p = 1 everywhere: the mask p / (p + 1) halves pixels
        def posterior(self, rgb):
            return np.full(rgb.shape[:-1], 0.5, np.float32)

    masked = Prefiltered(img, 0.8, lut=Half()).remap(mx, my).astype(float)
    half = cv2.remap(cv2.GaussianBlur((img * 0.5).round().astype(np.uint8), (3, 3), 0.8), mx, my,
                     cv2.INTER_LINEAR).astype(float)
    assert np.abs(masked - half).max() <= 1.0


def test_fast_paths_equal_numpys_bit_for_bit():
    """uint8 windows and templates take exact integer-sum shortcuts (channel means by one
    matrix product, per-channel centring): the same numbers as the generic float path."""
    from humimic.perception.blobs.zncc import _center_channels, zncc_windows

    rng = np.random.default_rng(11)
    windows = rng.integers(0, 256, (3, 9, 17, 17, 3)).astype(np.uint8)
    templates = rng.integers(0, 256, (3, 17, 17, 3)).astype(np.uint8)
    strips = rng.integers(0, 256, (3, 17, 40, 3)).astype(np.uint8)
    assert np.array_equal(zncc_windows(windows, templates),
                          zncc_windows(windows.astype(np.float32), templates.astype(np.float32)))
    assert np.array_equal(zncc_strips(strips, templates),
                          zncc_strips(strips.astype(np.float32), templates.astype(np.float32)))
    for dtype in (np.float32, np.float64):
        X = windows.reshape(3, 9, 289, 3).astype(dtype)
        ref = X - X.mean(axis=2, keepdims=True)
        _center_channels(X, integers=True)
        assert np.array_equal(X, ref)


def test_batched_reads_equal_single_reads():
    """read_batch (one float32 conversion and bound computation for all jobs) reads what each
    source's own remap reads."""
    from humimic.perception.blobs.zncc import Prefiltered, read_batch

    rng = np.random.default_rng(12)
    img = rng.integers(0, 256, (120, 160, 3)).astype(np.uint8)
    mx = rng.uniform(20, 140, (3, 17, 30))
    my = rng.uniform(20, 100, (3, 17, 30))
    spacing = [1.0, 3.2, 7.0]
    batch = read_batch([Prefiltered(img, 0.8, s) for s in spacing], mx, my)
    for r, s in enumerate(spacing):
        assert np.array_equal(batch[r], Prefiltered(img, 0.8, s).remap(mx[r], my[r]))


def test_closed_posterior_is_scipys_grey_closing():
    """The colour mask's closing (dilation, then erosion, by a square) against scipy.ndimage's
    grey_closing with the border replicated; a 1-px hole in a blob is filled, a 1-px speck
    outside stays, and a blob 3 px wide keeps its outline."""
    from scipy import ndimage

    from humimic.perception.blobs.zncc import closed_posterior

    rng = np.random.default_rng(3)
    post = rng.uniform(0, 1, (30, 40)).astype(np.float32)
    for r in (1, 2):
        ref = ndimage.grey_closing(post, size=(2 * r + 1, 2 * r + 1), mode="nearest")
        np.testing.assert_array_equal(closed_posterior(post, r), ref)
    assert closed_posterior(post, 0) is post
    blob = np.zeros((20, 20), np.float32)
    blob[5:15, 5:8] = 1.0
    blob[9, 6] = 0.0  # a hole
    blob[2, 15] = 1.0  # a speck
    out = closed_posterior(blob, 1)
    assert out[9, 6] == 1.0 and out[2, 15] == 1.0
    ref = np.zeros((20, 20))
    ref[5:15, 5:8] = 1.0
    np.testing.assert_array_equal(out[:, :14], ref[:, :14])
