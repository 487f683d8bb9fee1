"""Features on the projected model against closed forms: a cylinder parallel to the image plane
has straight, parallel image boundaries ``2 f r / sqrt(Z^2 - r^2)`` apart; a sphere on the
optical axis projects to a circle of radius ``f r / sqrt(Z^2 - r^2)``."""

from __future__ import annotations

import numpy as np
import pytest

from humimic.bodymodel.features import (
    contour_points,
    limb_bands,
    limb_edges,
    limb_ridges,
    resample,
)
from humimic.bodymodel.kinematics import Skeleton
from humimic.bodymodel.model import BodyModel, Ellipsoid, Part, cone_between
from humimic.bodymodel.projection import project
from humimic.sensors.camera_model import Intrinsics

INTR = Intrinsics(320, 240, 300.0, 300.0, 159.5, 119.5)
Z, R_CYL, R_BALL = 2.0, 0.05, 0.1


def _scene(n=3, shift=0.0):
    """A horizontal cylinder (camera x axis) at depth Z and a ball on the optical axis behind
    it; the torso frame is the camera frame (reference = camera)."""
    sk = Skeleton({"R": np.zeros(3), "L": np.zeros(3)}, np.zeros(3), 0.3, 0.25)
    parts = (cone_between("bar", "torso", (-0.3, shift, Z), (0.3, shift, Z), R_CYL, R_CYL,
                          x_hint=(0, 0, 1)),
             Part("ball", "torso", Ellipsoid((R_BALL,) * 3), np.eye(3), np.array([0, 0, 2 * Z])))
    body = BodyModel(sk, parts, free=("torso_x",))
    return body, body.forward(np.zeros((n, 1)))


def test_cylinder_edges_ridges_and_bands():
    body, pose = _scene()
    view = project(body, pose, INTR, np.eye(4), n_vertices=12)
    half = INTR.fy * R_CYL / np.sqrt(Z ** 2 - R_CYL ** 2)
    e = limb_edges(view, 20)
    assert e.ok.all()
    v = e.uv[0, 0, :, 1] - INTR.cy
    np.testing.assert_allclose(np.abs(v), half, atol=1e-9)
    assert (np.sign(v[:10]) == -np.sign(v[10:])).all()            # one half per side
    np.testing.assert_allclose(e.normal[0, 0, :, 1], np.sign(v), atol=1e-12)   # outwards
    assert abs(np.cos(e.angle[0, 0])) == pytest.approx(1.0)
    lean = limb_edges(view, 20, normals=False)          # the kpf's: the same without normals
    assert lean.normal is None and np.array_equal(lean.uv, e.uv)
    assert np.array_equal(lean.angle, e.angle) and np.array_equal(lean.ok, e.ok)
    r = limb_ridges(view, 30)
    np.testing.assert_allclose(r.width[0, 0], 2 * half, rtol=1e-9)
    np.testing.assert_allclose(r.uv[0, 0, :, 1], INTR.cy, atol=1e-9)
    np.testing.assert_allclose(r.depth[0, 0], Z, atol=1e-12)
    bands = limb_bands(view, 3, shrink=0.5)
    assert bands.shape == (3, 1, 3, 4, 2)
    np.testing.assert_allclose(np.abs(bands[0, 0, :, :, 1] - INTR.cy), half / 2, atol=1e-9)
    x = bands[0, 0, :, :, 0]
    assert np.ptp(x) == pytest.approx(INTR.fx * 0.6 / Z, rel=1e-3)   # bands tile the length


def test_resampled_contour_is_uniform_with_outward_normals():
    body, pose = _scene()
    view = project(body, pose, INTR, np.eye(4), n_vertices=64)
    pts = resample(view.outline, 40)
    ball = pts.uv[0, 1] - [INTR.cx, INTR.cy]
    radius = INTR.fx * R_BALL / np.sqrt((2 * Z) ** 2 - R_BALL ** 2)
    np.testing.assert_allclose(np.linalg.norm(ball, axis=1), radius, rtol=2e-3)
    np.testing.assert_allclose(pts.normal[0, 1], ball / np.linalg.norm(ball, axis=1)[:, None],
                               atol=0.06)                         # edge normals: within Δθ/2
    step = np.linalg.norm(np.diff(np.vstack([ball, ball[:1]]), axis=0), axis=1)
    assert step.std() / step.mean() < 1e-3
    np.testing.assert_allclose(1 / pts.inv_depth[0, 1], 2 * Z - R_BALL ** 2 / (2 * Z), rtol=1e-3)
    centre, axes, _ = view.ellipses_px()
    np.testing.assert_allclose(centre[0, 0], [INTR.cx, INTR.cy], atol=1e-9)
    np.testing.assert_allclose(axes[0, 0], [radius, radius], rtol=1e-9)
    bar = pts.uv[0, 0]
    on_side = np.abs(np.abs(bar[:, 1] - INTR.cy) - INTR.fy * R_CYL / np.sqrt(Z ** 2 - R_CYL ** 2))
    assert (on_side < 1e-6).sum() >= 30                         # most points on the long sides


def test_hidden_behind_the_bar_and_invalid_parts():
    body, pose = _scene()
    view = project(body, pose, INTR, np.eye(4), n_vertices=32)
    pts = contour_points(view, 40)
    ball_v = pts.uv[0, 1, :, 1] - INTR.cy
    bar_half = INTR.fy * R_CYL / np.sqrt(Z ** 2 - R_CYL ** 2)
    behind = np.abs(ball_v) < bar_half - 0.5
    assert behind.any() and (~pts.visible[0, 1, behind]).all()
    assert pts.visible[0, 1, np.abs(ball_v) > bar_half + 0.5].all()
    assert pts.visible[0, 0].all()                                # the bar is in front
    # a part behind the camera is invalid: no points, not visible, no NaN elsewhere
    body2, pose2 = _scene()
    T = np.eye(4)
    T[2, 3] = -5.0                                              # everything behind the camera
    view2 = project(body2, pose2, INTR, T, n_vertices=8)
    assert not view2.outline.valid.any()
    pts2 = contour_points(view2, 10)
    assert not pts2.visible.any() and np.isnan(pts2.uv).all()


def test_image_ellipses_match_the_pixel_conic():
    """``ellipses_px`` (the normalised ellipse mapped by K) against the ellipse of the pixel
    conic ``K^-T C K^-1`` (Menezes eq. 15 in pixels), for off-centre, rotated ellipsoids."""
    from humimic import bodymodel as bm
    from humimic.bodymodel import conics

    body = bm.avatar_body()
    rng = np.random.default_rng(4)
    q = np.zeros((20, 14))
    q[:, :3] = rng.uniform([-0.3, -0.3, -0.3], [0.3, 0.3, 0.3], (20, 3)) + [0.0, 0.0, 2.0]
    q[:, 3:] = rng.uniform(-0.6, 0.6, (20, 11))
    T = np.array([[0.0, -1, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0], [0, 0, 0, 1]])  # looks along +x
    q[:, 0] += 2.0
    view = project(body, body.forward(q), INTR, T)
    centre, axes, angle = view.ellipses_px()
    c_ref, M_ref, ok = conics.conic_to_ellipse(conics.conic_to_pixels(view.conic, INTR.K))
    major, minor, ang_ref = conics.ellipse_axes(M_ref)
    assert ok.sum() > 20
    np.testing.assert_allclose(centre[ok], c_ref[ok], atol=1e-6)
    np.testing.assert_allclose(axes[ok], np.stack([major, minor], -1)[ok], rtol=1e-6)
    d = np.angle(np.exp(2j * (angle[ok] - ang_ref[ok])))                     # axis: mod pi
    assert np.all(np.abs(d) < 1e-12)  # measured 9e-16 rad (was 1e-5)
