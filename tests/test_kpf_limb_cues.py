"""The compiled limb cues (:mod:`humimic.perception.trackers.kpf.limb_cues`) against the
numpy path they replace in the likelihood: the body model's feature points
(``bm.limb_edges``, ``limb_ridges``, ``limb_bands``, ``BodyView.ellipses_px``) sampled by
``cues.edge_response``, ``ridge_response``, ``band_colours``, ``skin_response`` (``cv2.remap``;
those are tested against OpenCV and the paper's formulas in ``test_kpf_cues.py``). Particles
spread widely round a pose in front of the camera (limbs off the image, seen end-on, behind
the camera: NaN ends), maps of a region (an origin) of a textured image, all pyramid levels."""

from __future__ import annotations

import _kpf_limb_cues as K
import cv2
import numpy as np
import pytest

from humimic import bodymodel as bm
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf import cues as C
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics

W, H = 320, 240


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(4)
    img = cv2.GaussianBlur(rng.integers(0, 255, (H, W, 3)).astype(np.uint8), (0, 0), 1.5)
    img[60:200, 120:200] = (224, 172, 140)           # a skin patch: skin fractions not all 0
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    body = kpf_body()
    intr = Intrinsics.from_fovy(0.9, W, H)
    # camera 2.5 m in front of the body, looking at it (base x forward, z up)
    T_cam_base = np.eye(4)
    T_cam_base[:3, :3] = [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
    T_cam_base[:3, 3] = T_cam_base[:3, :3] @ -np.array([-2.5, 0.0, 1.2])
    q0 = np.zeros(14)
    q0[:3] = (0.0, 0.0, 1.0)
    q0[3] = np.pi / 2                                # facing the camera
    D = np.r_[[0.4] * 3, [0.6] * 3, [1.5] * 8]       # wide: some parts off-image / end-on
    q = body.clamp(q0 + rng.uniform(-1.0, 1.0, (300, 14)) * D)
    view = bm.project(body, body.forward(q), intr, T_cam_base)
    view.sides_uv[:3], view.axis_uv[:3] = np.nan, np.nan     # as parts behind the camera
    view.sides_uv[3, 1, 0, :, 0] = 1e12                       # far off any image
    return img, lut, view


def same(got: np.ndarray, want: np.ndarray) -> bool:
    """Equal to float32 rounding where the numpy path is finite (it is NaN at NaN ends, which
    the likelihood masks as invalid parts; the kernels give NaN or 0 there)."""
    fin = np.isfinite(want)
    return (got.shape == want.shape and fin[3:].all()
            and np.allclose(got[fin], want[fin], atol=1e-6, rtol=0))


@pytest.mark.parametrize("colour_gradients", [False, True])
@pytest.mark.parametrize("region", [None, (40, 16, 300, 230)])
def test_compiled_limb_cues_equal_the_numpy_path(scene, colour_gradients, region):
    img, lut, view = scene
    maps = C.cue_maps(img, lut, region=region, colour_gradients=colour_gradients)
    assert np.isnan(view.sides_uv).any()             # the invalid cases are exercised
    js = np.arange(len(view.cone_idx))
    e = bm.limb_edges(view, 20, normals=False)
    got = K.edge_responses(maps, view.sides_uv, view.axis_uv, js, 20)
    want = C.edge_response(maps, e.uv, e.angle)
    assert same(got, want) and np.nanmax(want) > 0.1
    r = bm.limb_ridges(view, 30)
    got = K.ridge_responses(maps, view.sides_uv, view.axis_uv, js[1:], 30)
    levels = C.ridge_level(r.width.mean(-1), 3)
    assert set(np.unique(levels[np.isfinite(r.width.mean(-1))])) == {0, 1, 2}
    want = C.ridge_response(maps, r.uv, r.width.mean(-1), r.angle)[:, 1:]
    assert same(got, want) and np.nanmax(np.abs(want)) > 0.1
    for b in (3, 4):
        got = K.band_colours(maps, view.sides_uv, js[1:4], b, 0.2)
        want = C.band_colours(maps, bm.limb_bands(view, b, 0.2, js[1:4]))
        assert got.shape == want.shape and same(got, want)
    centre, axes, angle = view.ellipses_px()
    got = K.skin_fractions(maps, centre, axes, angle)
    want = C.skin_response(maps, centre, axes, angle)
    assert same(got, want) and 0.0 < np.nanmean(want) < 1.0


def test_compiled_limb_cues_of_no_particles(scene):
    img, lut, view = scene
    maps = C.cue_maps(img, lut)
    empty = np.zeros((0,) + view.sides_uv.shape[1:])
    assert K.edge_responses(maps, empty, empty[:, :, 0], [0, 1], 20).shape == (0, 2)
    assert K.band_colours(maps, empty, [1], 3, 0.2).shape == (0, 1, 3, 3)
