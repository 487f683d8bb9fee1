"""Ellipsoid projection (Menezes eqs. 14-15) against independent computations: the dual
quadric ``C* = P Q* P^T`` (Hartley & Zisserman eq. 8.5), densely sampled surface points
projected with ``cv2.projectPoints`` (all inside the ellipse, their hull on it), ray / unit
sphere intersection, and OpenCV's distortion model for the outline points."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.bodymodel import conics
from humimic.bodymodel.projection import project_ellipsoids
from humimic.sensors.camera_model import Intrinsics


def random_ellipsoids(rng, n):
    R = Rotation.random(n, random_state=rng).as_matrix()
    axes = rng.uniform(0.02, 0.2, (n, 3))
    t = np.column_stack([rng.uniform(-0.4, 0.4, n), rng.uniform(-0.3, 0.3, n),
                         rng.uniform(0.6, 3.0, n)])
    return R, t, axes


INTR = Intrinsics(320, 240, 260.0, 255.0, 161.3, 118.7)


def test_conic_matches_dual_quadric_projection():
    """Menezes' C = cA - bb^T (normalised camera, then K) equals (P Q* P^T)^-1 up to scale."""
    rng = np.random.default_rng(0)
    R, t, axes = random_ellipsoids(rng, 200)
    A, b, c = conics.ellipsoid_quadric(R, t, axes)
    C_px = conics.conic_to_pixels(conics.quadric_to_conic(A, b, c), INTR.K)
    worst = 0.0
    for i in range(len(R)):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R[i], t[i]
        Q_dual = T @ np.diag([*axes[i] ** 2, -1.0]) @ T.T           # H&Z: Q* = T D T^T
        P = INTR.K @ np.eye(3, 4)
        C_ref = np.linalg.inv(P @ Q_dual @ P.T)                       # H&Z eq. 8.5
        a = C_px[i] / np.linalg.norm(C_px[i])
        r = C_ref / np.linalg.norm(C_ref)
        worst = max(worst, min(np.abs(a - r).max(), np.abs(a + r).max()))
    assert worst < 1e-9


def _surface(R, t, axes, n=120):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n), np.linspace(0, np.pi, n // 2))
    s = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], -1).reshape(-1, 3)
    return (s * axes) @ R.T + t


def test_sampled_surface_lies_inside_the_ellipse_and_its_hull_on_it():
    rng = np.random.default_rng(1)
    R, t, axes = random_ellipsoids(rng, 40)
    outline, _, C = project_ellipsoids(R, t, axes, INTR, 256)
    centre, M, ok = conics.conic_to_ellipse(conics.conic_to_pixels(C, INTR.K))
    assert ok.all() and outline.valid.all()
    M_inv = np.linalg.inv(M)
    for i in range(len(R)):
        uv, _ = cv2.projectPoints(_surface(R[i], t[i], axes[i]), np.zeros(3), np.zeros(3),
                                  INTR.K, np.zeros(4))
        uv = uv[:, 0]
        d = uv - centre[i]
        radius = np.sqrt(np.einsum("ni,ij,nj->n", d, M_inv[i], d))
        assert radius.max() < 1.0 + 1e-9                  # every surface point inside
        hull = cv2.convexHull(uv.astype(np.float32))
        hd = hull[:, 0] - centre[i]
        assert np.sqrt(np.einsum("ni,ij,nj->n", hd, M_inv[i], hd)).min() > 0.998  # 0.9993
        # our outline points lie on the boundary of the sampled silhouette's hull
        dist = [cv2.pointPolygonTest(hull, (float(x), float(y)), True) for x, y in outline.uv[i]]
        assert np.max(np.abs(dist)) < 0.08  # px (measured 0.03 at 40-200 px ellipses)


def test_contour_points_are_tangent_points_on_the_ellipsoid():
    """Lifted with s0 = -b^T x / c: on the surface, and the ray is tangent there."""
    rng = np.random.default_rng(2)
    R, t, axes = random_ellipsoids(rng, 50)
    outline, _, _ = project_ellipsoids(R, t, axes, INTR, 32)
    X = np.concatenate([outline.xy, np.ones(outline.xy.shape[:-1] + (1,))], -1)
    X /= outline.inv_depth[..., None]                                   # 3-D contour points
    local = np.einsum("nji,nkj->nki", R, X - t[:, None]) / axes[:, None]
    assert np.abs(np.linalg.norm(local, axis=-1) - 1.0).max() < 1e-9
    normal = np.einsum("nij,nkj->nki", R, local / axes[:, None])         # gradient direction
    cos = np.sum(normal * X, -1) / np.linalg.norm(normal, axis=-1) / np.linalg.norm(X, axis=-1)
    assert np.abs(cos).max() < 1e-9


def test_ray_depth_matches_unit_sphere_intersection():
    rng = np.random.default_rng(3)
    R, t, axes = random_ellipsoids(rng, 300)
    A, b, c = conics.ellipsoid_quadric(R, t, axes)
    x = t[:, :2] / t[:, 2:] + rng.normal(0, 0.05, (300, 2))             # rays near the centre
    s = conics.ray_quadric_inverse_depth(A, b, c, x)
    # independent: in the ellipsoid's unit-sphere coordinates, |o + l d|^2 = 1
    d = np.einsum("nji,nj->ni", R, np.column_stack([x, np.ones(300)])) / axes
    o = np.einsum("nji,nj->ni", R, -t) / axes
    qa, qb, qc = np.sum(d * d, 1), np.sum(o * d, 1), np.sum(o * o, 1) - 1.0
    disc = qb ** 2 - qa * qc
    hit = disc >= 0
    lam = (-qb - np.sqrt(np.maximum(disc, 0))) / qa                      # depth (z of ray = l)
    assert 20 < hit.sum() < 300
    np.testing.assert_allclose(1.0 / s[hit], lam[hit], rtol=1e-9)
    assert np.all(s[~hit] == 0.0)


@pytest.mark.parametrize("k1,k2", [(-0.25, 0.08), (0.1, 0.0)])
def test_outline_pixels_follow_opencv_distortion(k1, k2):
    intr = Intrinsics(320, 240, 200.0, 200.0, 159.5, 119.5, k1, k2)
    rng = np.random.default_rng(4)
    R, t, axes = random_ellipsoids(rng, 20)
    outline, _, _ = project_ellipsoids(R, t, axes, intr, 24)
    X = np.concatenate([outline.xy, np.ones(outline.xy.shape[:-1] + (1,))], -1)
    X /= outline.inv_depth[..., None]
    ref, _ = cv2.projectPoints(X.reshape(-1, 3), np.zeros(3), np.zeros(3), intr.K, intr.dist)
    np.testing.assert_allclose(outline.uv.reshape(-1, 2), ref[:, 0], atol=1e-6)


def test_ellipse_axes_and_behind_camera_invalid():
    M = np.array([[[9.0, 0.0], [0.0, 4.0]], [[5.0, 3.0], [3.0, 5.0]]])
    major, minor, angle = conics.ellipse_axes(M)
    np.testing.assert_allclose(major, [3.0, np.sqrt(8.0)])
    np.testing.assert_allclose(minor, [2.0, np.sqrt(2.0)])
    np.testing.assert_allclose(angle, [0.0, np.pi / 4])
    R = np.eye(3)[None].repeat(3, 0)
    t = np.array([[0, 0, 1.0], [0, 0, 0.05], [0, 0, -1.0]])      # in front, straddling, behind
    outline, _, _ = project_ellipsoids(R, t, np.full((3, 3), 0.1), INTR, 8)
    assert outline.valid.tolist() == [True, False, False]
    assert np.isnan(outline.uv[1:]).all()


def test_dual_ellipse_matches_the_point_conic_and_the_inverted_dual_quadric():
    """The image ellipse in components from ``C* = B - t t^T`` against Menezes eq. 15's point
    conic ``C = cA - bb^T`` (:func:`conics.conic_to_ellipse`) and against the inverse of H&Z's
    projected dual quadric, for off-axis, rotated ellipsoids."""
    rng = np.random.default_rng(3)
    R, t, axes = random_ellipsoids(rng, 200)
    B = ((R * axes[:, None, :] ** 2) @ np.swapaxes(R, 1, 2)).reshape(-1, 9)[:, conics.UPPER]
    cx, cy, m00, m01, m11, k = conics.dual_ellipse(B, t)
    assert (k > 0).all()
    centre, M, ok = conics.conic_to_ellipse(conics.quadric_to_conic(
        *conics.ellipsoid_quadric(R, t, axes)))
    assert ok.all()
    np.testing.assert_allclose(np.c_[cx, cy], centre, atol=1e-12)
    np.testing.assert_allclose(np.c_[m00, m01, m11], M.reshape(-1, 4)[:, [0, 1, 3]],
                               rtol=1e-9, atol=1e-14)
    for i in range(0, 200, 20):                  # an ellipse's point conic from H&Z
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R[i], t[i]
        C = np.linalg.inv(np.eye(3, 4) @ T @ np.diag([*axes[i] ** 2, -1.0]) @ T.T
                          @ np.eye(3, 4).T)
        c = np.linalg.solve(C[:2, :2], -C[:2, 2])
        kappa = c @ C[:2, :2] @ c - C[2, 2]
        np.testing.assert_allclose([cx[i], cy[i]], c, atol=1e-12)
        np.testing.assert_allclose([[m00[i], m01[i]], [m01[i], m11[i]]],
                                   kappa * np.linalg.inv(C[:2, :2]), rtol=1e-9)


def test_rotated_ellipse_points_lie_on_their_ellipses_at_their_parameter_angles():
    """Each point, taken back into its ellipse's frame (closed form: rotate by -t), is
    ``(a cos psi, b sin psi)``; centres, axes and angles broadcast."""
    from humimic.bodymodel.conics import rotated_ellipse_points

    rng = np.random.default_rng(5)
    centre, ab = rng.uniform(0, 300, (4, 3, 2)), rng.uniform(1, 40, (4, 3, 2))
    t = rng.uniform(-np.pi, np.pi, (4, 3))
    psi = rng.uniform(0, 2 * np.pi, 9)
    p = rotated_ellipse_points(centre, ab, np.cos(t), np.sin(t),
                               np.stack([np.cos(psi), np.sin(psi)], -1))
    assert p.shape == (4, 3, 9, 2)
    d = p - centre[..., None, :]
    u = np.cos(t)[..., None] * d[..., 0] + np.sin(t)[..., None] * d[..., 1]
    v = -np.sin(t)[..., None] * d[..., 0] + np.cos(t)[..., None] * d[..., 1]
    np.testing.assert_allclose(u, ab[..., :1] * np.cos(psi), atol=1e-9)
    np.testing.assert_allclose(v, ab[..., 1:] * np.sin(psi), atol=1e-9)
