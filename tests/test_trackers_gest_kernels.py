"""GEST's compiled per-particle loops against the array operations they replace: the
projection of the hand ellipsoids (Menezes eq. 15, :func:`project_views` against
:func:`project_views_numpy`, distorted cameras, ellipsoids behind and straddling the camera),
the ellipse centres and outlines the silhouette offset and the stage use, the stereo cue
(:func:`blob_pair_log_likelihood`, ellipses off the image, no pair), the shape and
skin cues' samples (:func:`rim_distances`: the very numbers of :func:`shape_distance` and
:func:`skin_distance`), and the random walk's predictive densities over nested parts of the
state in one pass (:func:`walk_predictives` against :func:`walk_predictive_numpy` on each
part)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _synth_vision import stereo_head

from humimic.bodymodel.hand import hand_ellipsoids, to_camera
from humimic.bodymodel.projection import project_ellipsoids
from humimic.perception.trackers.gest.likelihood import (
    blob_pair_log_likelihood,
    blob_pair_log_likelihood_numpy,
    ellipse_centres,
    hand_outlines,
    hand_view,
    project_views,
    project_views_numpy,
    rim_distances,
    shape_distance,
    skin_distance,
)
from humimic.perception.trackers.gest.proposal import (
    walk_densities,
    walk_predictive_numpy,
    walk_predictives,
)
from humimic.sensors.camera_model import CameraImage, invert_transform

HAND = np.array([1.0, 0.05, 1.15, 0.3, 0.2, 1.2, 0.045, 0.022, 0.08])


def _states(rng: np.random.Generator, n: int, cam) -> np.ndarray:
    """Hands about ``HAND`` in any orientation and size, three of them in front of, across
    and behind ``cam``'s image plane."""
    states = HAND + np.c_[rng.normal(0, 0.15, (n, 3)), rng.uniform(-np.pi, np.pi, (n, 3)),
                          rng.uniform(-0.02, 0.04, (n, 3))]
    for i, depth in enumerate((0.3, 0.03, -1.0)):
        states[i, :3] = cam.T_base_cam[:3, :3] @ [0.05, -0.02, depth] + cam.T_base_cam[:3, 3]
    return states


def test_compiled_projection_is_the_array_form():
    cams = [replace(c, intrinsics=replace(c.intrinsics, fy=c.intrinsics.fy * 1.1, cy=110.0))
            for c in stereo_head()]         # radial distortion, fx != fy, cx != cy
    views = [hand_view(CameraImage(0.0, c, np.zeros((240, 320, 3), np.uint8)), 32)
             for c in cams]
    states = _states(np.random.default_rng(3), 200, cams[0])
    for image_views in (1, 2, None):
        projs, centres = project_views(states, views, 20, image_views)
        expect, expect_centres = project_views_numpy(states, views, 20, image_views)
        np.testing.assert_allclose(centres, expect_centres, rtol=1e-9, atol=1e-9)
        for p, e in zip(projs, expect, strict=True):
            assert (p is None) == (e is None)
            if p is None:
                continue
            assert p.valid.tolist() == e.valid.tolist() and not p.valid[1:3].any()
            assert p.valid.sum() > 150
            for f in ("contour", "normal", "patch_state"):
                np.testing.assert_allclose(getattr(p, f), getattr(e, f), rtol=1e-9, atol=1e-9)


def test_centres_and_outlines_are_the_compiled_projection_and_the_body_models():
    """:func:`ellipse_centres` (the silhouette offset's) against the array form's centres;
    :func:`hand_outlines` (the stage's) against the body model's own ellipsoid outlines
    (:func:`~humimic.bodymodel.projection.project_ellipsoids`, the point-conic form), NaN
    where the ellipsoid is not wholly in front of the camera."""
    cams = stereo_head()                                    # radial distortion
    states = _states(np.random.default_rng(4), 60, cams[0])
    views = [hand_view(CameraImage(0.0, c, np.zeros((240, 320, 3), np.uint8)), 32)
             for c in cams]
    np.testing.assert_allclose(ellipse_centres(states, views),
                               project_views_numpy(states, views, 8, 0)[1], rtol=1e-9, atol=1e-9)
    T = invert_transform(cams[0].T_base_cam)
    got = hand_outlines(states, cams[0].intrinsics, T, 16)
    R, c, axes = hand_ellipsoids(states)
    R, c = to_camera(T, R, c)
    want = project_ellipsoids(R[:, None], c[:, None], axes[:, None], cams[0].intrinsics, 16)[0]
    assert want.valid[:, 0].sum() > 40 and not want.valid[1:3, 0].any()
    assert (np.isfinite(got).all(axis=(1, 2)) == want.valid[:, 0]).all()
    np.testing.assert_allclose(got[want.valid[:, 0]], want.uv[want.valid[:, 0], 0], atol=1e-9)


def test_compiled_stereo_cue_is_the_array_form():
    rng = np.random.default_rng(5)
    centres = rng.normal(100.0, 3.0, (200, 2, 2))
    centres[:3] = -1.0e6                                    # invalid: off-image sentinel
    for m in (0, 1, 3):
        pairs = rng.normal(100.0, 2.0, (m, 2, 2))
        if m:
            centres[3] = pairs[-1] + 0.01                   # one ellipse pair on a blob pair
        for sigma, outlier in ((0.08, 1e-12), (1.5, 1e-6)):
            ours = blob_pair_log_likelihood(centres, pairs, sigma, outlier)
            expect = blob_pair_log_likelihood_numpy(centres, pairs, sigma, outlier)
            np.testing.assert_allclose(ours, expect, rtol=1e-9)
            assert (ours[:3] == np.log(outlier)).all()
            assert m == 0 or ours[3] > np.log(outlier) + 5.0
    with pytest.raises(ValueError, match="pairs"):           # pairs for three views, not two
        blob_pair_log_likelihood(centres, rng.normal(100.0, 2.0, (2, 3, 2)), 1.0, 1e-6)


def test_nested_walk_predictives_are_the_array_form_on_each_part():
    rng = np.random.default_rng(6)
    sigma = np.array([0.02, 0.02, 0.02, 0.0175, 0.0175, 0.0175, 1e-4, 1e-4, 1e-4])
    particles = HAND + rng.normal(0.0, 1.0, (80, 9)) * sigma * [5, 5, 5, 20, 20, 20, 8, 8, 8]
    x = particles[rng.integers(0, 80, 60)] + rng.normal(0.0, 1.0, (60, 9)) * sigma * 2
    lw = rng.normal(0.0, 3.0, 80)
    lw[:4] = -np.inf
    lw -= np.log(np.sum(np.exp(lw)))
    starts = (0, 3, 6)
    got = walk_predictives(x, particles, lw, sigma, starts)
    for s, row in zip(starts, got, strict=True):
        expect = walk_predictive_numpy(x[:, s:], particles[:, s:], lw, sigma[s:])
        np.testing.assert_allclose(row, expect, rtol=1e-9)
    np.testing.assert_array_equal(walk_densities(x, particles, lw, sigma), got)
    y = x.copy()
    y[0, 7] += sigma[7]                                     # not the kept call's arguments
    again = walk_densities(y, particles, lw, sigma)
    assert again[2, 0] != got[2, 0] and (again[:, 1:] == got[:, 1:]).all()
    for bad in ((3, 0), (0, 3, 3), (9,), (-1, 3)):           # the kernel fills ascending starts
        with pytest.raises(ValueError, match="starts"):
            walk_predictives(x, particles, lw, sigma, bad)


def test_rim_samples_are_the_shape_and_skin_cues_exactly():
    """The contour and rim points as one float32 two-channel map: the same bilinear samples
    as the cues' own one-channel maps, to the bit, contours across the image's edges too."""
    cam, _ = stereo_head()
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    image[rng.random((240, 320)) < 0.9] = 0                 # few edges: a spread-out DT
    view = hand_view(CameraImage(0.0, cam, image), 32)
    skin = rng.random((240, 320)).astype(np.float32)
    states = _states(rng, 150, cam)
    states[3:60, 1] += rng.uniform(-0.6, 0.6, 57)           # some across the image's sides
    assert view.skin is None and view.dt.max() > 3.0
    for v in (replace(view, skin=skin), view):
        proj = project_views(states, [v], 20)[0][0]
        assert (proj.contour < 0).any() and (proj.contour[..., 0] > 320).any()
        d, d_skin = rim_distances(proj, v)
        np.testing.assert_array_equal(d, shape_distance(proj, v))
        if v.skin is None:
            assert d_skin is None
        else:
            np.testing.assert_array_equal(d_skin, skin_distance(proj, v))


def test_rim_sampling_takes_more_rows_than_one_remap_call():
    """``cv2.remap`` refuses maps of 32767 rows or more; the rim cue samples 2 rows a particle
    (up to 20 000 particles): chunked, equal to one call on each half."""
    import numpy as np

    from humimic.perception.trackers.gest import likelihood

    rng = np.random.default_rng(0)
    img = rng.random((40, 50), dtype=np.float32)
    maps = rng.uniform(-5, 55, (2, 17000, 8, 2)).astype(np.float32)
    got = likelihood._sampled_mean(img, maps, 3.0)
    want = np.concatenate([likelihood._sampled_mean(img, maps[:, :8000], 3.0),
                           likelihood._sampled_mean(img, maps[:, 8000:], 3.0)], axis=1)
    np.testing.assert_array_equal(got, want)
