"""Colour GMMs (Ude eqs. 6-7): densities vs scipy, EM fit, HS conversion vs OpenCV, files."""

from __future__ import annotations

import colorsys
import json

import cv2
import numpy as np
import pytest
from scipy.stats import multivariate_normal

from humimic.perception.cues.color_models import (
    ColorLUT,
    ColorModel,
    fit_color_model,
    fit_gmm,
    gmm_log_density,
    load_color_model,
    rgb_to_hs,
    save_color_model,
)

SKIN = ColorModel(
    "rgb",
    np.array([0.6, 0.4]),
    np.array([[0.85, 0.62, 0.5], [0.7, 0.48, 0.38]]),
    np.array([np.diag([0.002, 0.0015, 0.0015]) + 0.0008,
              np.diag([0.003, 0.002, 0.002]) + 0.001]),
    "skin",
)


def _scipy_mixture(X, w, m, c):
    return sum(wk * multivariate_normal(mk, ck).pdf(X) for wk, mk, ck in
               zip(w, m, c, strict=True))


def test_rgb_likelihood_matches_scipy():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, size=(500, 3), dtype=np.uint8)
    rgb[:100] = np.clip(SKIN.means[0] * 255 + rng.normal(0, 10, (100, 3)), 0, 255)
    ours = SKIN.likelihood(rgb)
    ref = _scipy_mixture(rgb / 255.0, SKIN.weights, SKIN.means, SKIN.covs)
    np.testing.assert_allclose(ours, ref, rtol=1e-9, atol=1e-300)
    assert np.median(ours[:100]) > 10.0  # sanity: skin pixels far above uniform density (1)


def test_hs_conversion_matches_colorsys():
    """Against the standard library's per-pixel HSV (float64), an independent formula."""
    rng = np.random.default_rng(1)
    rgb = rng.random((64, 64, 3)).astype(np.float32)
    rgb[0, :8] = [[0.5, 0.5, 0.5]] * 8  # grey: saturation 0
    rgb[1, :8] = 0.0  # black
    ref = np.array([colorsys.rgb_to_hsv(*px) for px in rgb.reshape(-1, 3).astype(float)])
    hs = rgb_to_hs(rgb).reshape(-1, 2)
    dh = (hs[:, 0] - ref[:, 0] + 0.5) % 1.0 - 0.5
    assert np.abs(dh).max() < 2e-6  # float32 (measured 5e-7)
    np.testing.assert_allclose(hs[:, 1], ref[:, 1], atol=2e-6)
    assert rgb_to_hs(np.zeros((0, 3))).shape == (0, 2)


def test_hs_likelihood_matches_scipy_and_wraps_hue():
    w, m = np.array([1.0]), np.array([[0.01, 0.8]])
    c = np.array([[[4e-4, 1e-4], [1e-4, 3e-3]]])
    X = np.array([[0.02, 0.75], [0.0, 0.8], [0.995, 0.85], [0.03, 0.7]])
    ours = np.exp(gmm_log_density(X, w, m, c, circular=True))
    Xu = X.copy()
    Xu[:, 0] = np.where(Xu[:, 0] > 0.5, Xu[:, 0] - 1.0, Xu[:, 0])  # unwrapped around the mean
    np.testing.assert_allclose(ours, _scipy_mixture(Xu, w, m, c), rtol=1e-9)


def test_em_recovers_mixture_and_never_decreases_likelihood():
    rng = np.random.default_rng(42)
    true_m = np.array([[0.2, 0.3, 0.4], [0.7, 0.5, 0.3], [0.5, 0.8, 0.7]])
    true_c = np.array([np.diag([1e-3, 2e-3, 1e-3]), np.diag([2e-3, 1e-3, 1e-3]),
                       np.diag([1e-3, 1e-3, 3e-3])])
    true_w = np.array([0.5, 0.3, 0.2])
    n = rng.multinomial(6000, true_w)
    X = np.vstack([rng.multivariate_normal(m, c, size=k) for m, c, k in
                   zip(true_m, true_c, n, strict=True)])
    w, m, c, hist = fit_gmm(X, 3, np.random.default_rng(5))
    assert np.all(np.diff(hist) > -1e-9)
    order = [int(np.argmin(np.linalg.norm(m - tm, axis=1))) for tm in true_m]
    assert sorted(order) == [0, 1, 2]
    np.testing.assert_allclose(m[order], true_m, atol=0.01)
    np.testing.assert_allclose(w[order], true_w, atol=0.03)
    np.testing.assert_allclose(c[order], true_c, atol=4e-4)
    # ML fit is at least as likely as the generating parameters (checked with scipy)
    ll_fit = np.log(_scipy_mixture(X, w, m, c)).mean()
    ll_true = np.log(_scipy_mixture(X, true_w, true_m, true_c)).mean()
    assert ll_fit >= ll_true - 1e-9


def test_fit_hs_model_across_hue_wrap():
    rng = np.random.default_rng(3)
    hue = (rng.normal(0.0, 0.015, 3000)) % 1.0  # red: straddles hue 0
    sat = np.clip(rng.normal(0.8, 0.05, 3000), 0, 1)
    hsv = np.stack([hue * 360.0, sat, np.full(3000, 0.7)], -1).astype(np.float32)[None]
    rgb = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0]
    model = fit_color_model(rgb, "hs", 1, np.random.default_rng(0))
    assert min(model.means[0, 0], 1 - model.means[0, 0]) < 1e-3  # measured 3.1e-4 (was 0.003)
    assert model.covs[0, 0, 0] == pytest.approx(0.015**2, rel=0.04)  # measured 1.5 % off
    assert model.likelihood(np.array([[0.7, 0.14, 0.14]])) > 1.0  # red is likely, any intensity
    assert model.likelihood(np.array([[0.35, 0.07, 0.07]])) > 1.0
    assert model.likelihood(np.array([[0.14, 0.7, 0.14]])) < 1e-6  # green is not


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_save_load_roundtrip(tmp_path, suffix):
    p = tmp_path / f"skin{suffix}"
    save_color_model(SKIN, p)
    back = load_color_model(p)
    assert back.space == "rgb" and back.name == "skin"
    np.testing.assert_array_equal(back.covs, SKIN.covs)
    assert p.stat().st_size < 4000


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        load_color_model(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="malformed colour model file"):
        load_color_model(bad)
    bad.write_text(json.dumps({"format": "humimic.color_model", "space": "rgb", "weights": [1]}))
    with pytest.raises(ValueError, match="missing keys"):
        load_color_model(bad)
    bad.write_text(json.dumps({"format": "humimic.color_model", "space": "rgb", "weights": [1],
                               "means": [[0, 0]], "covs": [[[1, 0], [0, 1]]]}))
    with pytest.raises(ValueError, match="bad shapes"):
        load_color_model(bad)


def test_lut_close_to_exact_density():
    rng = np.random.default_rng(9)
    rgb = np.clip(SKIN.means[0] * 255 + rng.normal(0, 12, (2000, 3)), 0, 255).astype(np.uint8)
    exact = SKIN.likelihood(rgb)
    lut6 = ColorLUT(SKIN, bits=6).lookup(rgb)
    rel = np.abs(lut6 - exact) / exact
    # quantisation by up to 2 grey levels: measured median 0.10, 95th percentile 0.38 (7 bits:
    # 0.05, 0.17)
    assert np.median(rel) < 0.2 and np.quantile(rel, 0.95) < 0.5
    lut7 = ColorLUT(SKIN, bits=7).lookup(rgb)
    assert np.median(np.abs(lut7 - exact) / exact) < 0.1


def test_lut_posterior_table_equals_per_pixel_formula():
    """The tabulated p / (p + 1) is what computing it on looked-up densities gives."""
    rng = np.random.default_rng(4)
    pix = rng.integers(0, 256, (500, 3)).astype(np.uint8)
    model = fit_color_model(pix.astype(float), "rgb", 2, np.random.default_rng(0))
    lut = ColorLUT(model, 6)
    p = lut.lookup(pix)
    assert np.array_equal(lut.posterior(pix), p / (p + 1.0))
    img = rng.integers(0, 256, (7, 9, 3)).astype(np.uint8)
    q = img.astype(np.intp) >> 2
    assert np.array_equal(lut.index(img), q[..., 0] * 4096 + q[..., 1] * 64 + q[..., 2])


def test_lut_posterior_of_an_image_is_the_table_at_each_pixels_index():
    """The compiled image path: the posterior table at ``r' 4096 + g' 64 + b'`` per pixel
    (6 bits), for whole images and region views of one (any strides), as float32."""
    rng = np.random.default_rng(5)
    pix = rng.integers(0, 256, (300, 3)).astype(np.uint8)
    lut = ColorLUT(fit_color_model(pix.astype(float), "rgb", 2, np.random.default_rng(0)), 6)
    img = rng.integers(0, 256, (40, 50, 3)).astype(np.uint8)
    for view in (img, img[3:31, 7:40], img[::2, ::3], img[:1, :1], img[5:5]):
        q = view.astype(np.intp) >> 2
        expect = lut.post_table[q[..., 0] * 4096 + q[..., 1] * 64 + q[..., 2]]
        got = lut.posterior(view)
        assert got.dtype == np.float32 and got.shape == view.shape[:2]
        np.testing.assert_array_equal(got, expect)
