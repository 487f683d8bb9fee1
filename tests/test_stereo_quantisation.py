"""The disparity floor of a hard-edged blob outline (``perception.match_floor_px``): the match
error of flat discs rendered without anti-aliasing (each pixel in or out by its centre, as an
unmultisampled render) and colour-masked, at random sub-pixel positions, against the floor;
the floor's arithmetic and its plumbing into the stereo stage."""

from __future__ import annotations

import numpy as np
import pytest
from _synth_vision import add_noise, stereo_head

from humimic.perception.blobs.stereo import StereoRig
from humimic.perception.blobs.triangulation import match_noise_px

SKIN, BACKGROUND = (200, 150, 120), 90


class _BinaryLUT:
    """Skin where the red level is above 160 (the disc), never the grey background: a mask
    that keeps the render's hard edges hard."""

    @staticmethod
    def lookup(rgb):
        return np.where(np.asarray(rgb)[..., 0] > 160, 1e3, 0.0).astype(np.float32)

    def posterior(self, rgb):
        p = self.lookup(rgb)
        return p / (p + 1.0)


def _hard_disc(img, centre, radius):
    """Pixels whose centres lie inside the circle take the skin colour (no anti-aliasing)."""
    y, x = np.mgrid[0:img.shape[0], 0:img.shape[1]]
    inside = (x - centre[0]) ** 2 + (y - centre[1]) ** 2 <= radius**2
    img[inside] = SKIN
    return inside


def _disparity_errors(radius_m: float, n: int, seed: int) -> np.ndarray:
    """Depth errors of ``n`` discs (radius ``radius_m``, ~1.5 m away, random positions) as
    disparity errors (px), each matched from its mask centroid as the stage does."""
    rng = np.random.default_rng(seed)
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    rig, f = StereoRig(cam_l, cam_r), cam_l.intrinsics.fx
    c_l, c_r = cam_l.T_base_cam[:3, 3], cam_r.T_base_cam[:3, 3]
    baseline, mid = np.linalg.norm(c_r - c_l), 0.5 * (c_l + c_r)
    errs = []
    for _ in range(n):
        p_base = np.array([1.5 + rng.uniform(-0.05, 0.05), rng.uniform(-0.15, 0.15),
                           1.2 + rng.uniform(-0.1, 0.1)])
        imgs, centres, covs = [], [], []
        for cam in (cam_l, cam_r):
            img = np.full((240, 320, 3), BACKGROUND, np.uint8)
            r_px = f * radius_m / np.linalg.norm(p_base - cam.T_base_cam[:3, 3])
            ys, xs = np.nonzero(_hard_disc(img, cam.project_base(p_base), r_px))
            centres.append(np.array([xs.mean(), ys.mean()]))
            covs.append(np.cov(np.stack([xs, ys])))
            imgs.append(add_noise(img, rng, 2.0))
        m = rig.match(imgs[0], imgs[1], centres[0], covs[0], centres[1], covs[1],
                      0.01 * np.eye(2), 0.01 * np.eye(2), _BinaryLUT())
        assert m.ok, m.reason
        los = p_base - mid
        depth = np.linalg.norm(los)
        errs.append((m.p_base - p_base) @ los / depth * f * baseline / depth**2)
    return np.array(errs)


def test_hard_edged_outline_needs_the_floor():
    """Flat discs of sigma ~2.3 and ~4.6 px: the disparity error is a tenth of a pixel
    (measured RMS 0.091 / 0.097 / 0.104 px, seeds 1 / 3 / 5 of this test; 0.069-0.104 px per
    size over sigma 2.3-4.6 px, the floor the notes derive), twice the calibrated match_std
    (0.04 px, fitted on de-meaned errors); the worst disc 0.23-0.28 px."""
    e = np.concatenate([_disparity_errors(0.025, 30, 1), _disparity_errors(0.05, 30, 2)])
    rms = float(np.sqrt(np.mean(e**2)))
    assert 0.05 < rms < 0.2
    assert np.abs(e).max() < 0.5


def test_match_noise_px_against_hypot():
    ms, k = 0.04, np.array([1.0, 1.5, 2.0])
    np.testing.assert_allclose(match_noise_px(ms, k, 0.08), np.hypot(ms * k, 0.08), rtol=1e-12)
    np.testing.assert_array_equal(match_noise_px(ms, k), ms * k)


def test_core_adds_the_floor(monkeypatch):
    """PerceptionCore hands the stereo stage the grown match noise with the floor added in
    quadrature."""
    from test_perception_locks import Scripted

    from humimic.perception.blobs.triangulation import small_blob_scale

    calls = []

    def spy(self, il, ir, uv_l, cov_l, uv_r, cov_r, C_l, C_r, luts=None, match_std=None):
        calls.append((np.array(cov_l), np.array(match_std)))
        return [type("M", (), {"ok": False, "reason": "spy", "score": 0.0})()] * len(uv_l)

    monkeypatch.setattr(StereoRig, "match_many", spy)
    s = Scripted(pixel_std=0.3, match_std=0.05, match_floor_px=0.08)
    s.frames(12)
    assert calls
    cov_l, ms = calls[-1]
    np.testing.assert_allclose(ms, np.hypot(0.05 * small_blob_scale(cov_l, 5.0), 0.08))


def test_floor_needs_the_following_covariance():
    from humimic.perception.blobs.config import PerceptionConfig

    with pytest.raises(ValueError, match="following"):
        PerceptionConfig(match_floor_px=0.08, covariance="independent")
