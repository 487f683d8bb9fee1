"""Truncated elliptic cones seen by a pinhole camera: contour generators, outline, ray depth.

A cone part in its local frame: axis +z from the base rim at ``z = 0`` (semi-axes ``a`` along x,
``b`` along y) to the top rim at ``z = L`` (semi-axes ``k a``, ``k b``); ``k = 1`` is Schmidt's
elliptic cylinder, ``a = b`` Menezes' truncated circular cone. The solid is the convex hull of
its two rim discs, so its image silhouette is the convex hull of the two projected rim
ellipses: two straight *contour generators* (the lateral lines whose tangent plane contains
the camera centre) joined by an arc of each rim.

Contour generators, closed form. The lateral surface is
``P(phi, s) = (1 + (k-1) s) rho(phi) + s L z``, ``rho = (a cos phi, b sin phi, 0)``, with
outward normal ``n(phi) = (L b cos phi, L a sin phi, -(k-1) a b)`` (constant along a
generator). With the camera centre ``c`` in the local frame, the facing function
``n . (c - P) = A cos phi + B sin phi - C`` with ``A = L b c_x``, ``B = L a c_y``,
``C = a b (L + (k-1) c_z)`` is independent of ``s``; the generators are its zeros,
``phi = atan2(B, A) +- acos(C / sqrt(A^2 + B^2))``, and the lateral surface faces the camera
on the arc between them through ``atan2(B, A)``. The silhouette takes a rim's front-facing arc
unless the camera sees that rim's cap (``c_z < 0`` for the base, ``c_z > L`` for the top), then
its back-facing arc. Without generators (``|C| > sqrt(A^2 + B^2)``: looking into the cone along
its axis) the silhouette is one whole rim.

Units: metres; angles in radians.
"""

from __future__ import annotations

import numpy as np


def generator_angles(a, b, L, k, c_loc: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Contour-generator angles of cones seen from local camera centres ``c_loc (..., 3)``.

    Returns ``(phi_c, delta, exists, facing)``: the generators are at ``phi_c +- delta``
    (``phi_c`` = the middle of the front-facing arc); ``exists`` is False when the camera looks
    into the cone along its axis (then ``delta`` is 0 or pi and ``facing`` says whether the
    whole lateral surface faces the camera).
    """
    A = L * b * c_loc[..., 0]
    B = L * a * c_loc[..., 1]
    C = a * b * (L + (k - 1.0) * c_loc[..., 2])
    r = np.hypot(A, B)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = C / r
    exists = np.abs(ratio) < 1.0
    # NaN (r = 0: seen along the axis) as 1, +-inf clipped
    delta = np.arccos(np.where(np.isnan(ratio), 1.0, np.minimum(np.maximum(ratio, -1.0), 1.0)))
    return np.arctan2(B, A), delta, exists, C < 0.0


def outline_angles(phi_c: np.ndarray, delta: np.ndarray, exists: np.ndarray,
                   facing: np.ndarray, c_loc: np.ndarray, L, k, m: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rim angles ``(..., 4 + 2m)`` and rim index (0 base, 1 top) of the silhouette's vertices,
    and the index ``j (...)`` of the second generator's top end.

    Order: base and top ends of the generator at ``phi_c + delta``, ``m_top`` points inside the
    top rim's silhouette arc, top and base ends of the generator at ``phi_c - delta``
    (vertices ``j``, ``j + 1``), ``2m - m_top`` points inside the base rim's arc. The ``2m``
    arc points are shared in proportion to each arc's angular span times its rim's scale over
    its distance (a rough image length), so a cap seen nearly end-on gets most of them.
    Without generators, all ``4 + 2m`` vertices go round the silhouette rim.
    """
    c_z = c_loc[..., 2]
    g1, g2 = phi_c + delta, phi_c - delta
    top_front, base_front = c_z <= L, c_z >= 0.0
    front, back = 2.0 * delta, 2.0 * (np.pi - delta)
    top_span = np.where(top_front, -front, back)              # signed, from g1 to g2
    base_span = np.where(base_front, front, -back)            # signed, from g2 to g1
    d_top = np.linalg.norm(c_loc - np.stack([0 * c_z, 0 * c_z, 0 * c_z + L], -1), axis=-1)
    d_base = np.linalg.norm(c_loc, axis=-1)
    w_top = np.abs(top_span) * k / np.maximum(d_top, 1e-9)
    w_base = np.abs(base_span) / np.maximum(d_base, 1e-9)
    m_top = np.rint(2 * m * w_top / np.maximum(w_top + w_base, 1e-300)).astype(int)
    m_base = 2 * m - m_top
    slot = np.arange(4 + 2 * m)
    mt = m_top[..., None]
    on_top_arc = (slot >= 2) & (slot <= mt + 1)
    on_base_arc = slot >= mt + 4
    i_top = (slot - 1) / (mt + 1.0)
    i_base = (slot - mt - 3) / (m_base[..., None] + 1.0)
    phi = np.where(slot <= 1, g1[..., None], g2[..., None])
    phi = np.where(on_top_arc, g1[..., None] + top_span[..., None] * i_top, phi)
    phi = np.where(on_base_arc, g2[..., None] + base_span[..., None] * i_base, phi)
    rim = ((slot >= 1) & (slot <= mt + 2)).astype(int)
    # No generators: the rim that bounds the silhouette all round (the one whose cap the camera
    # sees if the lateral surface faces away; the far one if it all faces the camera).
    sees_top = c_z > L
    whole_rim = np.where(facing, ~sees_top, sees_top).astype(int)
    ring = 2.0 * np.pi * slot / len(slot)
    phi = np.where(exists[..., None], phi, ring)
    rim = np.where(exists[..., None], rim, whole_rim[..., None])
    return phi, rim, np.where(exists, m_top + 2, m + 2)


def rim_points(phi: np.ndarray, rim: np.ndarray, a, b, L, k, R: np.ndarray, t: np.ndarray,
               cos_sin: tuple[np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Camera coordinates ``X, Y, Z`` (each ``(..., V)``) of the points at rim angles ``phi``
    on rims ``rim`` (0 base, 1 top) of cones posed at ``R (..., 3, 3)``, ``t (..., 3)``;
    ``a, b, L, k`` broadcast against ``t[..., 0]`` (component form: numpy is slow on trailing
    axes of size 3). ``cos_sin``: ``cos phi, sin phi`` when the caller has them (``phi`` is
    then not used)."""
    scale = 1.0 + (np.asarray(k, float)[..., None] - 1.0) * rim
    cos, sin = (np.cos(phi), np.sin(phi)) if cos_sin is None else cos_sin
    lx = np.asarray(a, float)[..., None] * scale * cos
    ly = np.asarray(b, float)[..., None] * scale * sin
    lz = np.asarray(L, float)[..., None] * rim
    return tuple(t[..., i, None] + R[..., i, 0, None] * lx + R[..., i, 1, None] * ly
                 + R[..., i, 2, None] * lz for i in range(3))


def in_front(R: np.ndarray, t: np.ndarray, a, b, L, k, z_min: float = 1e-3) -> np.ndarray:
    """``(...)`` bool: both rims of cones posed at ``(R, t)`` in the camera lie at depth
    ``> z_min`` (then the whole convex solid does)."""
    ux, vy, w = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    reach0 = np.hypot(a * ux, b * vy)
    top_z = t[..., 2] + L * w
    return (t[..., 2] - reach0 > z_min) & (top_z - k * reach0 > z_min)


def ray_cone_depth(R: np.ndarray, t: np.ndarray, a, b, L, k, x: np.ndarray) -> np.ndarray:
    """Depth of the nearer intersection of the rays through normalised image points
    ``x (..., 2)`` with solid truncated cones posed at ``(R, t)`` in the camera (``inf`` where
    the ray misses). Lateral surface: the quadratic ``|p + l q|^2 = (g0 + l g1)^2`` in the
    ray's depth ``l`` (``p, q`` the ray's origin and direction scaled by ``1/a, 1/b``;
    ``g0 + l g1`` the cross-section scale), kept where ``0 <= z <= L``; caps: the planes
    ``z = 0`` and ``z = L`` inside their ellipses."""
    # Ray X = l (x, y, 1) in the camera; local: o + l d with o = -R^T t, d = R^T (x, y, 1)
    # (component form: fast on long 1-D batches).
    u, v = x[..., 0], x[..., 1]
    t0, t1, t2 = t[..., 0], t[..., 1], t[..., 2]

    def col(i):
        return R[..., 0, i], R[..., 1, i], R[..., 2, i]

    (r0x, r1x, r2x), (r0y, r1y, r2y), (r0z, r1z, r2z) = col(0), col(1), col(2)
    px = -(r0x * t0 + r1x * t1 + r2x * t2) / a
    py = -(r0y * t0 + r1y * t1 + r2y * t2) / b
    pz = -(r0z * t0 + r1z * t1 + r2z * t2)
    qx = (r0x * u + r1x * v + r2x) / a
    qy = (r0y * u + r1y * v + r2y) / b
    qz = r0z * u + r1z * v + r2z
    g0 = 1.0 + (k - 1.0) * pz / L
    g1 = (k - 1.0) * qz / L
    qa = qx * qx + qy * qy - g1 * g1
    qb = px * qx + py * qy - g0 * g1
    qc = px * px + py * py - g0 * g0
    disc = qb * qb - qa * qc
    root = np.sqrt(np.maximum(disc, 0.0))
    best = np.full(np.broadcast(qa, qb).shape, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for sign in (-1.0, 1.0):
            lam = (-qb + sign * root) / qa
            z = pz + lam * qz
            ok = (disc >= 0.0) & (lam > 0.0) & (z >= 0.0) & (z <= L) & (g0 + lam * g1 > 0.0)
            best = np.where(ok & (lam < best), lam, best)
        for z_cap, scale in ((0.0, 1.0), (L, k)):
            lam = (z_cap - pz) / qz
            ex, ey = px + lam * qx, py + lam * qy
            ok = (lam > 0.0) & (ex * ex + ey * ey <= scale * scale)
            best = np.where(ok & (lam < best), lam, best)
    return best
