"""Truncated elliptic cones against independent computations: the silhouette against the
convex hull (``cv2.convexHull``) of densely sampled surface points projected with
``cv2.projectPoints``, the contour generators against finite-difference surface normals, and the
ray depth against ray marching with a point-in-solid test."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from humimic.bodymodel import cones
from humimic.bodymodel.projection import project_cones
from humimic.sensors.camera_model import Intrinsics

INTR = Intrinsics(320, 240, 250.0, 250.0, 159.5, 119.5)


def random_cones(rng, n, end_on=0):
    """Cones in front of the camera; the last ``end_on`` look (nearly) along their axis."""
    R = Rotation.random(n, random_state=rng).as_matrix()
    a, b = rng.uniform(0.02, 0.15, n), rng.uniform(0.02, 0.15, n)
    L, k = rng.uniform(0.1, 0.5, n), rng.uniform(0.4, 1.6, n)
    t = np.column_stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.2, n),
                         rng.uniform(0.8, 2.5, n)])
    for i in range(n - end_on, n):
        z = -t[i] / np.linalg.norm(t[i]) + rng.normal(0, 0.02, 3)   # axis towards the camera
        z *= rng.choice([-1.0, 1.0])                              # towards or away
        z /= np.linalg.norm(z)
        x = np.cross(z, [0.3, 1.0, 0.2])
        x /= np.linalg.norm(x)
        R[i] = np.stack([x, np.cross(z, x), z], 1)
    keep = cones.in_front(R, t, a, b, L, k, 0.05)
    return R[keep], t[keep], a[keep], b[keep], L[keep], k[keep]


def surface_points(R, t, a, b, L, k, n=360):
    """Dense samples of the whole surface (lateral, both caps) in the camera frame."""
    phi = np.linspace(0, 2 * np.pi, n, endpoint=False)
    s = np.linspace(0, 1, 25)[:, None]
    lateral = np.stack([(1 + (k - 1) * s) * a * np.cos(phi), (1 + (k - 1) * s) * b * np.sin(phi),
                        np.broadcast_to(s * L, (25, n))], -1).reshape(-1, 3)
    r = np.linspace(0, 1, 10)[:, None]
    caps = [np.stack([r * sc * a * np.cos(phi), r * sc * b * np.sin(phi),
                      np.full((10, n), z)], -1).reshape(-1, 3) for z, sc in ((0, 1), (L, k))]
    return np.concatenate([lateral, *caps]) @ R.T + t


def _hull(R, t, a, b, L, k):
    uv, _ = cv2.projectPoints(surface_points(R, t, a, b, L, k), np.zeros(3), np.zeros(3),
                              INTR.K, np.zeros(4))
    return cv2.convexHull(uv[:, 0].astype(np.float32))


def _iou(p, q):
    inter, _ = cv2.intersectConvexConvex(p.astype(np.float32), q.astype(np.float32))
    return inter / (cv2.contourArea(p.astype(np.float32)) + cv2.contourArea(
        q.astype(np.float32)) - inter)


def test_silhouette_is_the_hull_of_the_projected_surface():
    rng = np.random.default_rng(0)
    R, t, a, b, L, k = random_cones(rng, 60, end_on=12)
    fine, gen, _ = project_cones(R, t, a, b, L, k, INTR, 64)
    coarse, _, _ = project_cones(R, t, a, b, L, k, INTR, 6)
    assert fine.valid.all() and 5 < (~gen).sum() < 12 + 5        # end-on ones have no generators
    worst_d, worst_iou, worst_coarse = 0.0, 1.0, 1.0
    for i in range(len(t)):
        hull = _hull(R[i], t[i], a[i], b[i], L[i], k[i])
        d = [cv2.pointPolygonTest(hull, (float(x), float(y)), True) for x, y in fine.uv[i]]
        worst_d = max(worst_d, np.max(np.abs(d)))
        worst_iou = min(worst_iou, _iou(fine.uv[i], hull[:, 0]))
        worst_coarse = min(worst_coarse, _iou(coarse.uv[i], hull[:, 0]))
    assert worst_d < 0.1           # px: every outline vertex on the hull's boundary (0.04)
    assert worst_iou > 0.998       # (0.9993)
    assert worst_coarse > 0.95     # 16 vertices (0.967; a 16-gon in an ellipse: 0.974)


def test_generators_are_where_the_surface_turns_away():
    """At the generator angles the finite-difference surface normal is perpendicular to the
    line of sight, along the whole generator."""
    rng = np.random.default_rng(1)
    R, t, a, b, L, k = random_cones(rng, 40)
    c_loc = -np.einsum("nji,nj->ni", R, t)
    phi_c, delta, exists, _ = cones.generator_angles(a, b, L, k, c_loc)
    assert exists.sum() > 30
    a, b, L, k, c_loc, phi_c, delta = (v[exists] for v in (a, b, L, k, c_loc, phi_c, delta))
    h = 1e-6

    def P(phi, s):
        g = 1 + (k - 1) * s
        return np.stack([g * a * np.cos(phi), g * b * np.sin(phi), s * L], -1)

    for phi in (phi_c + delta, phi_c - delta):
        for s in (0.1, 0.5, 0.9):
            n = np.cross((P(phi + h, s) - P(phi - h, s)), (P(phi, s + h) - P(phi, s - h)))
            view = c_loc - P(phi, s)
            cos = np.sum(n * view, -1) / np.linalg.norm(n, axis=-1) / np.linalg.norm(view, axis=-1)
            assert np.abs(cos).max() < 6e-10  # measured <= 2.0e-10 (was 1e-6)


def test_ray_depth_matches_ray_marching():
    rng = np.random.default_rng(2)
    R, t, a, b, L, k = random_cones(rng, 40, end_on=8)
    step = 2e-4
    lam = np.arange(0.3, 4.0, step)
    hits = misses = 0
    for i in range(len(t)):
        outline, _, _ = project_cones(R[i:i + 1], t[i:i + 1], a[i], b[i], L[i], k[i], INTR, 16)
        centre = outline.xy[0].mean(0)
        for x in centre + rng.normal(0, 0.04, (6, 2)):
            depth = cones.ray_cone_depth(R[i], t[i], a[i], b[i], L[i], k[i], x)
            X = lam[:, None] * np.array([x[0], x[1], 1.0])
            p = (X - t[i]) @ R[i]                                        # local
            g = 1 + (k[i] - 1) * p[:, 2] / L[i]
            inside = ((p[:, 2] >= 0) & (p[:, 2] <= L[i])
                      & ((p[:, 0] / a[i]) ** 2 + (p[:, 1] / b[i]) ** 2 <= g * g))
            if inside.any():
                hits += 1
                assert abs(depth - lam[np.argmax(inside)]) <= step
            else:
                misses += 1
                assert np.isinf(depth)
    assert hits > 50 and misses > 20
