"""Schmidt et al.'s image cues (eqs. 1-8) on synthetic images: a bright bar on a dark ground
at a known angle and width, a coloured patch, a skin disc. Each response is checked against
the geometry (the bar's boundary and axis, its angle, its width) and, for the edge cue,
against OpenCV's Sobel gradient at the same pixels."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf import cues as C

H, W = 120, 160
SKIN = (224, 172, 140)


@pytest.fixture(scope="module")
def lut():
    return ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)


def bar_image(angle: float, width: float, centre=(80.0, 60.0)) -> np.ndarray:
    """Grey 40 ground, a 200 bar of ``width`` px through ``centre`` along ``angle``."""
    img = np.full((H, W, 3), 40, np.uint8)
    c, s = np.cos(angle), np.sin(angle)
    vv, uu = np.mgrid[0:H, 0:W]
    across = -(uu - centre[0]) * s + (vv - centre[1]) * c
    img[np.abs(across) <= width / 2] = 200
    return img


def along(angle: float, offset: float, n: int = 20, centre=(80.0, 60.0)) -> np.ndarray:
    """``n`` points on the line at ``offset`` px across the bar's axis, (1, 1, n, 2)."""
    c, s = np.cos(angle), np.sin(angle)
    t = np.linspace(-30, 30, n)
    u = centre[0] + t * c - offset * s
    v = centre[1] + t * s + offset * c
    return np.stack([u, v], -1)[None, None]


def test_edge_cue_peaks_on_the_boundary_at_the_limb_angle(lut):
    a, width = np.radians(30.0), 12.0
    maps = C.cue_maps(bar_image(a, width), lut)
    on = C.edge_response(maps, along(a, width / 2), np.array([[a]]))[0, 0]
    off = C.edge_response(maps, along(a, width / 2 + 8), np.array([[a]]))[0, 0]
    crossed = C.edge_response(maps, along(a, width / 2), np.array([[a + np.pi / 2]]))[0, 0]
    assert on > 0.8 and off < 0.1 and crossed < 0.15   # measured 0.88, 0.0, 0.054
    # eq. 1 is the gradient's component across the limb: OpenCV's Sobel says the same
    g = cv2.GaussianBlur(cv2.cvtColor(bar_image(a, width), cv2.COLOR_RGB2GRAY)
                         .astype(np.float32) / 255, (5, 5), 1.0)
    gx, gy = cv2.Sobel(g, cv2.CV_32F, 1, 0), cv2.Sobel(g, cv2.CV_32F, 0, 1)
    p = np.rint(along(a, width / 2)[0, 0]).astype(int)
    across = np.abs(gy[p[:, 1], p[:, 0]] * np.cos(a) - gx[p[:, 1], p[:, 0]] * np.sin(a))
    mag = np.hypot(gx, gy)[p[:, 1], p[:, 0]]
    # float32 maps: measured 4.1e-8 (the bound was 1e-3, then 1e-6 + 1e-5 relative); float32
    # bounds in this file sit ~10x above the measured rounding (SIMD order varies by CPU)
    assert np.allclose(across / mag, np.abs(
        maps.grad[1].ravel()[p[:, 1] * W + p[:, 0]] * np.cos(a)
        - maps.grad[0].ravel()[p[:, 1] * W + p[:, 0]] * np.sin(a))
        / np.hypot(maps.grad[0], maps.grad[1]).ravel()[p[:, 1] * W + p[:, 0]], rtol=0,
        atol=5e-7)


@pytest.mark.parametrize("width", [4.0, 8.0, 16.0])
def test_ridge_cue_on_the_axis_at_the_width_level(lut, width):
    a = np.radians(-50.0)
    maps = C.cue_maps(bar_image(a, width), lut)
    w = np.array([[width]])
    on = C.ridge_response(maps, along(a, 0.0, 30), w, np.array([[a]]))[0, 0]
    beside = C.ridge_response(maps, along(a, width * 1.5 + 4, 30), w, np.array([[a]]))[0, 0]
    crossed = C.ridge_response(maps, along(a, 0.0, 30), w, np.array([[a + np.pi / 2]]))[0, 0]
    assert on > 0.5 and beside < 0.2 and crossed < -0.5  # measured 1.10-1.11, 0.0, -1.10-1.11
    assert C.ridge_level(np.array([width]), 3)[0] == int(np.clip(np.rint(np.log2(width / 4)),
                                                                  0, 2))


def test_sampling_and_ridge_match_direct_indexing_and_the_paper_formula(lut):
    """``sample`` (cv2.remap) against numpy indexing with np.rint, off-image points and NaN
    giving 0; the ridge response (its complex form, levels side by side) against eq. 3-4's
    ``|s^2 uu + c^2 vv - 2 sc uv| - |c^2 uu + s^2 vv + 2 sc uv|`` on OpenCV's own pyramid."""
    rng = np.random.default_rng(2)
    img = rng.integers(0, 255, (H, W, 3)).astype(np.uint8)
    img = cv2.GaussianBlur(img, (0, 0), 2.0)
    maps = C.cue_maps(img, lut)
    uv = np.stack([rng.uniform(-20, W + 20, (50, 4, 30)), rng.uniform(-20, H + 20, (50, 4, 30))],
                  -1)
    uv[0, 0, :3] = np.nan
    uv[1, 1, :5, 0] = np.rint(uv[1, 1, :5, 0]) + 0.5                      # ties: half to even
    ui, vi = np.rint(uv[..., 0]), np.rint(uv[..., 1])
    with np.errstate(invalid="ignore"):
        inside = (ui >= 0) & (ui < W) & (vi >= 0) & (vi < H)
    ui, vi = np.where(inside, ui, 0).astype(int), np.where(inside, vi, 0).astype(int)
    want = np.where(inside[..., None], maps.rgb[vi, ui], 0.0)
    assert np.array_equal(C.sample(maps.rgb, uv), want)
    # ridge: every level, angles all round
    width = np.array([2.0, 8.0, 16.0, 40.0])[None].repeat(50, 0)              # levels 0,1,2,2
    angle = rng.uniform(-np.pi, np.pi, (50, 4))
    g = cv2.GaussianBlur(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32) / 255,
                         (5, 5), 1.0)
    levels = [g, cv2.pyrDown(g), cv2.pyrDown(cv2.pyrDown(g))]
    want = np.zeros((50, 4))
    for n in range(50):
        for j, mu in enumerate(C.ridge_level(width[n], 3)):
            lv = levels[mu]
            uu, uv_, vv = (cv2.Sobel(lv, cv2.CV_32F, dx, dy, ksize=3) / 4.0
                           for dx, dy in ((2, 0), (1, 1), (0, 2)))
            norm = np.tanh(np.sqrt(uu ** 2 + uv_ ** 2 + vv ** 2) / 0.05) / np.maximum(
                np.sqrt(uu ** 2 + uv_ ** 2 + vv ** 2), 1e-6)
            s, c = np.sin(angle[n, j]), np.cos(angle[n, j])
            x, y = np.rint(uv[n, j, :, 0] * 0.5 ** mu), np.rint(uv[n, j, :, 1] * 0.5 ** mu)
            with np.errstate(invalid="ignore"):
                ok = (x >= 0) & (x < lv.shape[1]) & (y >= 0) & (y < lv.shape[0])
            x, y = np.where(ok, x, 0).astype(int), np.where(ok, y, 0).astype(int)
            a, b, d = (m[y, x] * norm[y, x] for m in (uu, uv_, vv))
            r = np.abs(s * s * a + c * c * d - 2 * s * c * b) - np.abs(c * c * a + s * s * d
                                                                       + 2 * s * c * b)
            want[n, j] = np.mean(np.where(ok, r, 0.0))
    # measured 1.5e-8 (2026-11-29; the bound was 1e-5 + 1e-5 relative)
    assert np.allclose(C.ridge_response(maps, uv, width, angle), want, rtol=0, atol=2e-7)


def test_colour_and_skin_cues(lut):
    img = np.full((H, W, 3), 30, np.uint8)
    img[20:60, 20:60] = (200, 40, 40)
    cv2.circle(img, (110, 80), 15, SKIN, -1)
    maps = C.cue_maps(img, lut)
    quad = np.array([[25, 25], [55, 25], [55, 55], [25, 55]], float)[None, None]
    colour = C.band_colours(maps, quad[:, :, None])[0, 0, 0]
    assert np.allclose(colour, np.array([200, 40, 40]) / 255, rtol=0, atol=1e-6)  # 7.3e-8
    ref = np.array([[[200, 40, 40]]]) / 255
    assert C.colour_response(C.band_colours(maps, quad[:, :, None]), ref)[0, 0] < 1e-6
    skin = C.skin_response(maps, np.array([[[110.0, 80.0], [40.0, 40.0]]]),
                           np.array([[[12.0, 10.0], [12.0, 10.0]]]), np.zeros((1, 2)))
    assert skin[0, 0] == 1.0 and skin[0, 1] == 0.0
    off_image = C.skin_response(maps, np.array([[[-50.0, -50.0]]]), np.array([[[5.0, 5.0]]]),
                                np.zeros((1, 1)))
    assert off_image[0, 0] == 0.0


def test_likelihood_is_the_balanced_product_of_cue_gaussians():
    """Eqs. 9-10 as a product: prod_l prod_c exp(-e^2 / 2 sigma_c^2)^(1 / N_l), against the
    log-sum the tracker uses (fixed sigmas)."""
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.likelihood import CUE_NAMES, Likelihood
    from humimic.perception.trackers.kpf.tracker import kpf_body
    from humimic.sensors.camera_model import Intrinsics

    cfg = KpfConfig(sigma_from_spread=False)
    lik = Likelihood(kpf_body(), Intrinsics.from_fovy(0.8, 320, 240), cfg)
    rng = np.random.default_rng(0)
    cost = {c: np.where(lik.used[c], rng.uniform(0, 1, (5, len(lik.parts))), np.nan)
            for c in CUE_NAMES}
    prod = np.ones(5)
    for j, part in enumerate(lik.parts):
        cues = lik.use[part]
        for c in cues:
            sigma = getattr(cfg.sigma, c)
            prod *= np.exp(-cost[c][:, j] ** 2 / (2 * sigma ** 2)) ** (1 / len(cues))
    assert np.allclose(lik.combine(cost).sum(axis=1), np.log(prod))


def test_colour_gradients_find_an_edge_grey_levels_miss(lut):
    """Our ``colour_gradients`` extension: a bar whose colour differs from the ground's but not
    its grey level has no grey edge; the strongest channel's derivatives equal scipy's per
    channel (Gaussian 5 x 5, sigma 1; Sobel / 8; mirrored borders), and on a grey image the
    maps equal the grey-level ones."""
    from scipy import ndimage

    a, width = np.radians(30.0), 12.0
    img = bar_image(a, width).astype(float)
    bar = img[..., 0] > 100
    grey = np.array([0.299, 0.587, 0.114])
    ground, colour = np.array([120.0, 120.0, 120.0]), np.array([200.0, 103.0, 60.0])
    colour += (grey @ ground - grey @ colour) / grey.sum()     # the same grey level
    img = np.rint(np.where(bar[..., None], colour, ground)).clip(0, 255).astype(np.uint8)
    plain = C.cue_maps(img, lut)
    rich = C.cue_maps(img, lut, colour_gradients=True)
    pts, ang = along(a, width / 2), np.array([[a]])
    assert C.edge_response(plain, pts, ang)[0, 0] < 0.05
    assert C.edge_response(rich, pts, ang)[0, 0] > 0.4    # 0.56: red steps by 80 levels
    # the raw derivatives of the strongest channel, independently
    f = img.astype(np.float64) / 255.0
    blur = np.stack([ndimage.gaussian_filter(f[..., k], 1.0, truncate=2.0, mode="mirror")
                     for k in range(3)], -1)
    du = np.stack([ndimage.sobel(blur[..., k], axis=1, mode="mirror") for k in range(3)], -1) / 8
    dv = np.stack([ndimage.sobel(blur[..., k], axis=0, mode="mirror") for k in range(3)], -1) / 8
    k = np.argmax(du ** 2 + dv ** 2, axis=-1)[..., None]
    gu, gv = (np.take_along_axis(d, k, -1)[..., 0] for d in (du, dv))
    mag = np.hypot(gu, gv)
    want = np.stack([gu, gv]) * np.tanh(mag / 0.15) / np.maximum(mag, 1e-6)
    # measured 2.5e-7 (2026-11-29; the bound was 2e-4)
    assert np.allclose(rich.grad, want, rtol=0, atol=3e-6)
    # achromatic: the same maps as grey levels
    g = C.cue_maps(bar_image(a, width), lut, colour_gradients=True)
    ref = C.cue_maps(bar_image(a, width), lut)
    # measured 0 and 1.45e-6 (2026-11-29; the bounds were 1e-4)
    assert np.allclose(g.gradient, ref.gradient, rtol=0, atol=1e-6)
    assert np.allclose(g.ridge, ref.ridge, rtol=0, atol=1.5e-5)


def test_strongest_channel_is_the_argmax_of_the_squared_sums():
    """The selection (numpy's and the compiled one the maps use) against a per-pixel loop in
    Python floats (the first channel on ties): the values of the
    chosen channel, copied exactly, and the compiled one's norm."""
    rng = np.random.default_rng(5)
    planes = [rng.normal(size=(23, 31, 3)).astype(np.float32) for _ in range(3)]
    for p in planes:
        p[:4, :, 1] = p[:4, :, 0]                  # ties between channels 0 and 1
        p[4:6, :, 2] = p[4:6, :, 0]                # ... and 0 and 2
    for k in (2, 3):
        want = np.empty((k, 23, 31), np.float32)
        norm = np.empty((23, 31), np.float32)
        for y in range(23):
            for x in range(31):
                sq = [sum(float(planes[i][y, x, c]) ** 2 for i in range(k)) for c in range(3)]
                c = sq.index(max(sq))              # the first on ties
                want[:, y, x] = [planes[i][y, x, c] for i in range(k)]
                norm[y, x] = np.sqrt(sq[c])
        got = C.strongest_channel(*planes[:k])
        assert all(np.array_equal(g, w) for g, w in zip(got, want, strict=True))
        sel, mag = C._strongest_norm(*planes[:k])
        assert np.array_equal(sel, want)
        assert np.allclose(mag, norm, rtol=1e-6, atol=0)
    grey = rng.normal(size=(5, 7)).astype(np.float32)
    assert C.strongest_channel(grey, grey)[0] is grey
