"""Colour cue (Menezes eqs. 6, 13), fusion (eq. 7) and importance functions (eqs. 8, 9, 12)
against OpenCV and closed forms."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.stats import multivariate_normal

from humimic.perception.cues.fusion import fuse
from humimic.perception.cues.histograms import (
    HEAD_TORSO_PATCHES,
    bhattacharyya,
    color_log_likelihood,
    patch_histograms,
    quantize,
    update_reference,
)
from humimic.perception.cues.importance import (
    detection_proposal,
    mixed_proposal,
    recognition_proposal,
    skin_blobs,
)


def _image(seed=0):
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (120, 160, 3), dtype=np.uint8)
    img[30:70, 40:80] = rng.integers(150, 256, (40, 40, 3), dtype=np.uint8)
    return img


@pytest.fixture
def full_grid_hists():
    img = _image()
    q = quantize(img, 32)
    state = np.array([[49.5, 41.5, 1.0]])
    patch = np.array([[0.0, 0.0, 20.0, 20.0]])
    return img, patch_histograms(q, state, patch, grid=20)


def test_full_grid_histogram_is_calchist(full_grid_hists):
    img, h = full_grid_hists
    roi = img[32:52, 40:60]
    for c in range(3):
        ref = cv2.calcHist([roi], [c], None, [32], [0, 256])[:, 0]
        np.testing.assert_allclose(h[0, 0, c], ref / ref.sum())


def test_bhattacharyya_matches_numpy_and_opencv():
    rng = np.random.default_rng(1)
    a, b = rng.random((5, 32)), rng.random((5, 32))
    a /= a.sum(1, keepdims=True)
    b /= b.sum(1, keepdims=True)
    ours = bhattacharyya(a, b)
    numpy_ref = np.sqrt(1.0 - np.sum(np.sqrt(a * b), axis=1))
    cv_ref = [cv2.compareHist(x.astype(np.float32), y.astype(np.float32),
                              cv2.HISTCMP_BHATTACHARYYA) for x, y in zip(a, b, strict=True)]
    np.testing.assert_allclose(ours, numpy_ref, atol=1e-12)
    np.testing.assert_allclose(ours, cv_ref, atol=1e-6)
    assert bhattacharyya(a[0], a[0]) == pytest.approx(0.0, abs=1e-7)
    assert bhattacharyya(np.zeros(32), a[0]) == 1.0  # an empty patch is as far as can be


def test_colour_likelihood_eq6_and_reference_update_eq13():
    img = _image()
    q = quantize(img)
    states = np.array([[60.0, 50.0, 20.0], [120.0, 90.0, 20.0], [-500.0, 0.0, 20.0]])
    h = patch_histograms(q, states, HEAD_TORSO_PATCHES)
    refs = h[0]
    lam = np.array([[1.0, 0.5, 0.2], [0.3, 1.0, 2.0]])
    ll = color_log_likelihood(h, refs, sigma=0.03, weights=lam)
    D = np.sqrt(np.clip(1 - np.sum(np.sqrt(h * refs[None]), -1), 0, 1))
    np.testing.assert_allclose(ll, -np.sum(lam * D**2, axis=(1, 2)) / (2 * 0.03**2))
    assert ll[0] == pytest.approx(0.0, abs=1e-9) and ll[1] < ll[0]
    assert np.all(h[2] == 0) and ll[2] == pytest.approx(-lam.sum() / (2 * 0.03**2))
    new = update_reference(refs, h[1], np.array([0.1, 0.05]))
    np.testing.assert_allclose(new[0], 0.9 * refs[0] + 0.1 * h[1, 0])
    np.testing.assert_allclose(new[1], 0.95 * refs[1] + 0.05 * h[1, 1])
    np.testing.assert_allclose(new.sum(-1), 1.0)
    np.testing.assert_array_equal(update_reference(refs, h[2], 0.1), refs)  # nothing seen


def test_fusion_is_the_product_of_likelihoods():
    a, b, c = np.log([0.2, 0.5]), np.log([0.1, 0.9]), np.array([-np.inf, 0.0])
    np.testing.assert_allclose(np.exp(fuse(a, b)), [0.02, 0.45])
    assert fuse(a, b, c)[0] == -np.inf
    with pytest.raises(ValueError):
        fuse()


def test_importance_functions_eq8_eq9_eq12():
    centers = np.array([[100.0, 50.0], [200.0, 120.0], [40.0, 40.0]])
    rng = np.random.default_rng(2)
    x = centers[rng.integers(0, 3, 50)] + rng.normal(0.0, 12.0, (50, 2))
    pi = detection_proposal(centers, (6.0, 8.0))
    ref = np.mean([multivariate_normal(c, np.diag([36.0, 64.0])).pdf(x) for c in centers], 0)
    np.testing.assert_allclose(np.exp(pi.log_density(x)), ref, rtol=1e-9)
    probs = np.array([0.7, 0.0, 0.3])
    rec = recognition_proposal(centers, probs, (6.0, 6.0))
    ref = sum(p * multivariate_normal(c, 36.0 * np.eye(2)).pdf(x)
              for c, p in zip(centers, probs, strict=True))
    np.testing.assert_allclose(np.exp(rec.log_density(x)), ref, rtol=1e-9)
    assert len(rec.means) == 2  # the other person's face does not propose
    blobs = detection_proposal(np.array([[160.0, 200.0]]), (6.0, 6.0))
    mixed = mixed_proposal(pi, blobs, detection_proposal(np.zeros((0, 2))))
    np.testing.assert_allclose(np.exp(mixed.log_density(x)),
                               0.5 * np.exp(pi.log_density(x)) + 0.5 * np.exp(
                                   blobs.log_density(x)), rtol=1e-9)
    with3 = detection_proposal(centers, (6.0, 6.0), sizes=[30, 40, 50], sigma_s=3.0)
    s = with3.sample(3000, np.random.default_rng(0))
    # measured 40.02; 0.5 is ~3 standard errors of the mean of 3000 (was 1.0)
    assert s.shape == (3000, 3) and abs(s[:, 2].mean() - 40.0) < 0.5


def test_skin_blobs_centroids_and_filters():
    mask = np.zeros((240, 320), np.uint8)
    cv2.circle(mask, (100, 80), 12, 255, -1)  # a face-sized blob
    cv2.ellipse(mask, (220, 150), (8, 14), 0, 0, 360, 255, -1)  # a hand
    mask[10:12, 10:200] = 255  # a thin line: aspect ratio out of range
    mask[200, 300] = 255  # a speck: too small
    b = skin_blobs(mask, subsample=2, min_area_px=40, aspect=(0.3, 3.0))
    assert len(b.centers) == 2
    order = np.argsort(b.centers[:, 0])
    for k, (u, v) in zip(order, [(100, 80), (220, 150)], strict=True):
        assert np.hypot(*(b.centers[k] - [u, v])) < 1.0
    assert b.areas[order[0]] == pytest.approx(np.pi * 12**2, rel=0.005)  # measured 0.09 % off


def test_colour_likelihood_from_counts_is_calchist_and_comparehist():
    """Eq. 6 straight from the bin counts (``patch_color_log_likelihood``) against OpenCV's
    histogram of the patch and its Bhattacharyya distance; an off-image patch is at D = 1 in
    every channel, a patch half off the image counts the pixels on it only."""
    from humimic.perception.cues.histograms import patch_color_log_likelihood

    img = _image()
    q = quantize(img, 32)
    rng = np.random.default_rng(5)
    ref = rng.random((1, 3, 32))
    ref /= ref.sum(-1, keepdims=True)
    states = np.array([[49.5, 41.5, 20.0], [150.5, 9.5, 20.0], [-500.0, -500.0, 20.0]])
    patch = np.array([[0.0, 0.0, 1.0, 1.0]])
    sigma = 0.3
    ours = patch_color_log_likelihood(q, states, patch, ref, sigma, grid=20)
    expect = []
    for roi in (img[32:52, 40:60], img[0:20, 141:160], img[:0, :0]):
        d2 = 0.0
        for c in range(3):
            if roi.size == 0:
                d2 += 1.0
                continue
            h = cv2.calcHist([roi], [c], None, [32], [0, 256])[:, 0]
            d2 += cv2.compareHist((h / h.sum()).astype(np.float32),
                                  ref[0, c].astype(np.float32), cv2.HISTCMP_BHATTACHARYYA) ** 2
        expect.append(-d2 / (2 * sigma ** 2))
    np.testing.assert_allclose(ours, expect, atol=2e-5)


def test_chromaticity_closed_form_and_shading_invariance():
    """Normalised rgb against a per-pixel loop; halving the light leaves it (to one count of
    rounding), dark pixels are grey."""
    from humimic.perception.cues.histograms import chromaticity

    rng = np.random.default_rng(3)
    img = rng.integers(40, 256, (6, 7, 3)).astype(np.uint8)
    img[0, 0] = (5, 10, 3)                                   # dark: grey
    out = chromaticity(img)
    for i in range(6):
        for j in range(7):
            r, g, b = (float(c) for c in img[i, j])
            s = r + g + b
            want = [85, 85, 85] if s < 72 else [int(255 * c / s + 0.5) for c in (r, g, b)]
            assert out[i, j].tolist() == want, (i, j)
    half = (img.astype(float) * 0.5).round().astype(np.uint8)
    bright = img.sum(axis=-1) >= 200
    diff = np.abs(chromaticity(half).astype(int) - out.astype(int))[bright]
    assert diff.max() <= 2, diff.max()


def test_compiled_counts_and_colour_cue_are_the_array_form():
    """The compiled bin counts are the array form's to the count, and eq. 6 from them to
    rounding, for patches on, across and off the image's edges (and a state that is NaN)."""
    from humimic.perception.cues.histograms import (
        patch_color_log_likelihood,
        patch_color_log_likelihood_numpy,
        patch_counts,
        patch_counts_numpy,
    )

    rng = np.random.default_rng(4)
    q = quantize(rng.integers(0, 256, (90, 120, 3), dtype=np.uint8), 16)
    patches = np.array([[0.0, 0.0, 1.0, 1.0], [0.2, 1.5, 1.6, 0.8]])
    refs = rng.random((2, 3, 16))
    refs /= refs.sum(-1, keepdims=True)
    states = np.c_[rng.uniform(-30, 150, (300, 2)), rng.uniform(0.5, 40, 300)]
    states[0] = (-500.0, -500.0, 10.0)                      # wholly off the image
    states[1, 0] = np.nan
    for grid in (8, 13):
        counts, total = patch_counts(q, states, patches, grid)
        ours = patch_color_log_likelihood(q, states, patches, refs, 0.3, grid)
        with np.errstate(invalid="ignore"):                 # the NaN state's cast
            expect_counts, expect_total = patch_counts_numpy(q, states, patches, grid)
            expect = patch_color_log_likelihood_numpy(q, states, patches, refs, 0.3, grid)
        np.testing.assert_array_equal(counts, expect_counts)
        np.testing.assert_array_equal(total, expect_total)
        assert (total[:2] == 0).all() and total.max() == grid**2
        assert ((total > 0) & (total < grid**2)).sum() > 20            # across the edges
        np.testing.assert_allclose(ours, expect, rtol=1e-9)
        assert (ours[:2] == -6.0 / (2 * 0.3**2)).all()      # D = 1 in every patch, channel


def test_colour_cue_rejects_references_of_another_bin_count():
    """The compiled cue reads the references unchecked: a mismatch is refused up front."""
    from humimic.perception.cues.histograms import patch_color_log_likelihood, quantize

    q = quantize(np.zeros((8, 8, 3), np.uint8), 16)
    with pytest.raises(ValueError, match="refs has shape"):
        patch_color_log_likelihood(q, np.zeros((2, 3)), np.ones((1, 4)), np.ones((1, 3, 8)), 0.1)


def test_compiled_lut_index_is_the_lut_s_index():
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model, lut_index

    px = np.random.default_rng(5).integers(0, 256, (500, 3), dtype=np.uint8)
    px[:3] = [[0, 0, 0], [255, 255, 255], [255, 0, 128]]
    for bits in (5, 6, 8):  # the index needs no densities: an empty table, not 2^24 of them
        lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), bits,
                       table=np.zeros(1 << 3 * bits, np.float32))
        got = [lut_index(r, g, b, bits) for r, g, b in px]
        np.testing.assert_array_equal(got, lut.index(px))
