"""Project a posed body model into a camera: one convex outline per part and particle.

:func:`project` returns a :class:`BodyView`: for N particles and P parts, the silhouette of
each part as an ordered convex polygon of V vertices (``uv`` pixels with the camera's
distortion, ``xy`` undistorted normalised coordinates, ``inv_depth`` 1/m), plus what the
feature samplers and hidden-part removal need (quadrics of the ellipsoids, poses of the cones,
the limbs' image axes). Every vertex is the image of a 3-D point on the part's contour
generator, mapped to pixels by :meth:`humimic.sensors.camera_model.Intrinsics.distort` (the one
projection implementation; distortion included).

* Ellipsoids: quadric -> conic (Menezes eqs. 14-15, :mod:`humimic.bodymodel.conics`), V points
  on the image ellipse, each lifted to its 3-D tangent point (``s0 = -b^T x / c``).
* Cones: the closed-form contour generators and rim arcs (:mod:`humimic.bodymodel.cones`);
  vertices 0-1 and ``second``-``second + 1`` are the two generators (limb boundary lines).

A part is ``valid`` where it lies wholly in front of the camera (``z > z_min``); invalid parts'
vertices are NaN. Cost: see ``benchmarks/bench_bodymodel.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from humimic.bodymodel import cones, conics
from humimic.bodymodel.model import BodyModel, Cone, Pose
from humimic.sensors.camera_model import Intrinsics

#: Nearest depth (m) a valid part may reach.
Z_MIN = 0.02


@dataclass(frozen=True)
class Outline:
    """Ordered convex outlines of ``(N, P)`` parts, V vertices each."""

    uv: np.ndarray
    """(N, P, V, 2) pixels (distorted as the camera)."""
    xy: np.ndarray
    """(N, P, V, 2) undistorted normalised image coordinates."""
    inv_depth: np.ndarray
    """(N, P, V) 1 / depth of the 3-D contour point (1/m)."""
    valid: np.ndarray
    """(N, P) bool: the part lies wholly in front of the camera."""


def _pixels(intr: Intrinsics, xy: np.ndarray) -> np.ndarray:
    """Undistorted normalised points ``(..., 2)`` to pixels (the camera's distortion)."""
    return np.stack(intr.distort(xy[..., 0], xy[..., 1]), axis=-1)


def project_ellipsoids(R: np.ndarray, t: np.ndarray, semi_axes: np.ndarray, intr: Intrinsics,
                       n_vertices: int) -> tuple[Outline, tuple, np.ndarray]:
    """Outlines of ellipsoids posed at ``R (..., 3, 3)``, ``t (..., 3)`` in the camera with
    ``semi_axes (..., 3)`` (m). Returns the outline, the quadric blocks ``(A, b, c)`` and the
    normalised conics ``C (..., 3, 3)`` (Menezes eq. 15)."""
    A, b, c = conics.ellipsoid_quadric(R, t, semi_axes)
    C = conics.quadric_to_conic(A, b, c)
    centre, M, ok = conics.conic_to_ellipse(C)
    reach_z = np.sqrt(np.sum(np.square(R[..., 2, :] * semi_axes), axis=-1))
    valid = ok & (c > 0.0) & (t[..., 2] - reach_z > Z_MIN)
    xy = conics.ellipse_points(centre, M, n_vertices)
    s0 = conics.contour_inverse_depth(b, c, xy)
    xy = np.where(valid[..., None, None], xy, np.nan)
    return Outline(_pixels(intr, xy), xy, s0, valid), (A, b, c), C


def project_cones(R: np.ndarray, t: np.ndarray, a, b, L, k, intr: Intrinsics, m: int
                  ) -> tuple[Outline, np.ndarray, np.ndarray]:
    """Outlines (``4 + 2m`` vertices) of cones posed at ``R (..., 3, 3)``, ``t (..., 3)`` in the
    camera; ``a, b, L, k`` broadcast against ``t[..., 0]``. Also returns ``(...)`` bool: the
    contour generators exist (False: seen along the axis, the outline is one rim), and the
    index ``j (...)`` of the vertices ``j`` (top) and ``j + 1`` (base) of the second generator
    (the first is vertices 0 (base) and 1 (top))."""
    c_loc = -(t[..., None, :] @ R)[..., 0, :]
    phi_c, delta, exists, facing = cones.generator_angles(a, b, L, k, c_loc)
    phi, rim, second = cones.outline_angles(phi_c, delta, exists, facing, c_loc, L, k, m)
    p_loc = cones.rim_points(phi, rim, a, b, L, k)
    X = p_loc @ np.swapaxes(R, -1, -2) + t[..., None, :]
    valid = cones.in_front(R, t, a, b, L, k, Z_MIN)
    X = np.where(valid[..., None, None], X, np.nan)
    inv_z = 1.0 / X[..., 2]
    xy = X[..., :2] * inv_z[..., None]
    return Outline(_pixels(intr, xy), xy, inv_z, valid), exists, second


@dataclass(frozen=True, eq=False)
class BodyView:
    """A body model seen by one camera, for N particles (see the module docstring)."""

    part_names: tuple[str, ...]
    intrinsics: Intrinsics
    outline: Outline
    cone_idx: np.ndarray
    """(Pc,) indices (into parts) of the cones."""
    ellipsoid_idx: np.ndarray
    """(Pe,) indices of the ellipsoids."""
    cone_R: np.ndarray
    """(N, Pc, 3, 3) ``R_cam_part`` of the cones."""
    cone_t: np.ndarray
    """(N, Pc, 3) base-rim centres in the camera (m)."""
    cone_shape: np.ndarray
    """(Pc, 4) ``a, b, length, taper`` of the cones."""
    generators: np.ndarray
    """(N, Pc) bool: the cone's contour generators exist (not seen end-on)."""
    second: np.ndarray
    """(N, Pc) int: vertices ``second`` (top) and ``second + 1`` (base) of a cone's outline are
    its second contour generator (the first: vertices 0 (base) and 1 (top))."""
    quadric: tuple[np.ndarray, np.ndarray, np.ndarray]
    """Blocks ``A (N, Pe, 3, 3), b (N, Pe, 3), c (N, Pe)`` of the ellipsoids' quadrics."""
    conic: np.ndarray
    """(N, Pe, 3, 3) the ellipsoids' image conics, normalised coordinates (Menezes eq. 15)."""
    m: int
    """Arc vertices of a cone outline are ``2 m`` (V = 4 + 2 m)."""
    axis_xyz: np.ndarray
    """(N, Pc, 2, 3) the cones' axis ends (base, top rim centres) in the camera (m)."""
    axis_uv: np.ndarray
    """(N, Pc, 2, 2) the cones' axis ends in pixels."""

    @property
    def n(self) -> int:
        return self.outline.uv.shape[0]

    def index(self, name: str) -> int:
        return self.part_names.index(name)

    @property
    def limb_names(self) -> tuple[str, ...]:
        """Names of the cone parts, in the order of the limb features (axis 1)."""
        return tuple(self.part_names[i] for i in self.cone_idx)


def project(body: BodyModel, pose: Pose, intr: Intrinsics, T_cam_ref: np.ndarray,
            n_vertices: int = 16) -> BodyView:
    """Every part of ``body`` at ``pose`` seen by a camera with intrinsics ``intr`` at
    ``T_cam_ref`` (4x4: reference-frame points -> camera frame, OpenCV axes), e.g.
    ``invert_transform(camera.T_base_cam)`` when the torso pose is in the robot's base frame.
    ``n_vertices`` = V >= 6, even (cones: 4 generator ends and ``V - 4`` rim-arc points)."""
    if n_vertices < 6 or n_vertices % 2:
        raise ValueError(f"project: n_vertices must be even and >= 6, got {n_vertices}")
    m = (n_vertices - 4) // 2
    R_ref, p_ref = body.part_frames(pose)
    R_c = np.asarray(T_cam_ref, float)[:3, :3]
    R = R_c @ R_ref
    t = p_ref @ R_c.T + np.asarray(T_cam_ref, float)[:3, 3]
    n, P = t.shape[:2]
    kinds = [isinstance(p.shape, Cone) for p in body.parts]
    ci = np.array([i for i, k in enumerate(kinds) if k], int)
    ei = np.array([i for i, k in enumerate(kinds) if not k], int)
    uv = np.empty((n, P, n_vertices, 2))
    xy = np.empty((n, P, n_vertices, 2))
    inv_z = np.empty((n, P, n_vertices))
    valid = np.empty((n, P), bool)

    shape = np.array([[s.a, s.b, s.length, s.taper] for s in
                      (body.parts[i].shape for i in ci)]).reshape(-1, 4)
    gen, second = np.zeros((n, 0), bool), np.zeros((n, 0), int)
    if len(ci):
        out, gen, second = project_cones(R[:, ci], t[:, ci], *shape.T, intr, m)
        uv[:, ci], xy[:, ci], inv_z[:, ci], valid[:, ci] = (
            out.uv, out.xy, out.inv_depth, out.valid)
    quad = (np.zeros((n, 0, 3, 3)), np.zeros((n, 0, 3)), np.zeros((n, 0)))
    conic = np.zeros((n, 0, 3, 3))
    if len(ei):
        axes = np.array([body.parts[i].shape.semi_axes for i in ei], float)
        out, quad, conic = project_ellipsoids(R[:, ei], t[:, ei], axes, intr, n_vertices)
        uv[:, ei], xy[:, ei], inv_z[:, ei], valid[:, ei] = (
            out.uv, out.xy, out.inv_depth, out.valid)
    R_cone, t_cone = R[:, ci], t[:, ci]
    axis_xyz = np.stack([t_cone, t_cone + R_cone[..., :, 2] * shape[:, 2, None]], axis=-2)
    return BodyView(body.part_names, intr, Outline(uv, xy, inv_z, valid), ci, ei, R_cone,
                    t_cone, shape, gen, second, quad, conic, m, axis_xyz,
                    intr.project(axis_xyz))
