"""Project a posed body model into a camera, for N particles at once.

:func:`project` returns a :class:`BodyView`. Computed at once (cheap, ``(N, parts)`` arrays):
which parts lie wholly in front of the camera (``valid``), the cones' contour generators
(the limbs' two boundary lines, closed form, :mod:`humimic.bodymodel.cones`) and image axes,
and the ellipsoids' quadrics and image conics (Menezes eqs. 14-15,
:mod:`humimic.bodymodel.conics`). Computed on first use of ``view.outline``: every part's
silhouette as an ordered convex polygon of V vertices -- ``uv`` pixels, ``xy`` undistorted
normalised coordinates, ``inv_depth`` 1/m -- each vertex the image of a 3-D point on the
part's contour generator (ellipsoids: points of the image ellipse lifted with
``s0 = -b^T x / c``; cones: generator ends and rim arcs). Pixels come from
:meth:`humimic.sensors.camera_model.Intrinsics.distort` (the one projection implementation;
distortion included).

Invalid parts' vertices are NaN. Cost: ``benchmarks/bench_bodymodel.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from humimic.bodymodel import cones, conics
from humimic.bodymodel.model import BodyModel, Pose
from humimic.maths.arrays import stack
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
    return stack(intr.distort(xy[..., 0], xy[..., 1]), axis=-1)


def _image(intr: Intrinsics, XYZ: tuple, valid: np.ndarray) -> Outline:
    """Camera-frame points (components ``X, Y, Z``, each ``(..., V)``) as an
    :class:`Outline` (NaN where not ``valid``)."""
    X, Y, Z = XYZ
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_z = np.where(valid[..., None], 1.0 / Z, np.nan)
    x, y = X * inv_z, Y * inv_z
    return Outline(stack(intr.distort(x, y), axis=-1), stack([x, y], axis=-1), inv_z,
                   valid)


def project_ellipsoids(R: np.ndarray, t: np.ndarray, semi_axes: np.ndarray, intr: Intrinsics,
                       n_vertices: int) -> tuple[Outline, tuple, np.ndarray]:
    """Outlines of ellipsoids posed at ``R (..., 3, 3)``, ``t (..., 3)`` in the camera with
    ``semi_axes (..., 3)`` (m). Returns the outline, the quadric blocks ``(A, b, c)`` and the
    normalised conics ``C (..., 3, 3)`` (Menezes eq. 15)."""
    A, b, c = conics.ellipsoid_quadric(R, t, semi_axes)
    C = conics.quadric_to_conic(A, b, c)
    centre, M, ok = conics.conic_to_ellipse(C)
    valid = ok & (c > 0.0) & _ellipsoid_in_front(R, t, semi_axes)
    return _ellipse_outline(intr, centre, M, b, c, valid, n_vertices), (A, b, c), C


def _ellipsoid_in_front(R, t, semi_axes) -> np.ndarray:
    reach_z = np.sqrt(np.add.reduce(np.square(R[..., 2, :] * semi_axes), axis=-1))
    return t[..., 2] - reach_z > Z_MIN


def _ellipse_outline(intr, centre, M, b, c, valid, n_vertices) -> Outline:
    xy = conics.ellipse_points(centre, M, n_vertices)
    s0 = conics.contour_inverse_depth(b, c, xy)
    xy = np.where(valid[..., None, None], xy, np.nan)
    return Outline(_pixels(intr, xy), xy, s0, valid)


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
    XYZ = cones.rim_points(phi, rim, a, b, L, k, R, t)
    return _image(intr, XYZ, cones.in_front(R, t, a, b, L, k, Z_MIN)), exists, second


@dataclass(frozen=True, eq=False)
class BodyView:
    """A body model seen by one camera, for N particles (see the module docstring)."""

    part_names: tuple[str, ...]
    intrinsics: Intrinsics
    n_vertices: int
    """Vertices V of each part's outline."""
    valid: np.ndarray
    """(N, P) bool: the part lies wholly in front of the camera."""
    cone_idx: np.ndarray
    """(Pc,) indices (into parts) of the cones: the limbs of the limb features."""
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
    sides_uv: np.ndarray
    """(N, Pc, 2, 2, 2) the contour generators in pixels: ``[:, :, side, end]``, end 0 on the
    base rim, 1 on the top rim (NaN where invalid)."""
    axis_xyz: np.ndarray
    """(N, Pc, 2, 3) the cones' axis ends (base, top rim centres) in the camera (m)."""
    axis_uv: np.ndarray
    """(N, Pc, 2, 2) the cones' axis ends in pixels."""
    quadric: tuple[np.ndarray, np.ndarray, np.ndarray]
    """Blocks ``A (N, Pe, 3, 3), b (N, Pe, 3), c (N, Pe)`` of the ellipsoids' quadrics."""
    conic: np.ndarray
    """(N, Pe, 3, 3) the ellipsoids' image conics, normalised coordinates (Menezes eq. 15)."""
    ellipse: tuple[np.ndarray, np.ndarray]
    """Centres ``(N, Pe, 2)`` and shape matrices ``(N, Pe, 2, 2)`` of the ellipsoids' image
    ellipses, normalised coordinates (:func:`conics.ellipse_axes` gives axes and angle)."""
    cone_view: tuple[np.ndarray, ...]
    """``(c_loc, phi_c, delta, facing)`` of the cones (for the outlines)."""

    @property
    def n(self) -> int:
        return self.valid.shape[0]

    def index(self, name: str) -> int:
        return self.part_names.index(name)

    @property
    def limb_names(self) -> tuple[str, ...]:
        """Names of the cone parts, in the order of the limb features (axis 1)."""
        return tuple(self.part_names[i] for i in self.cone_idx)

    def ellipses_px(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ellipsoids' image ellipses in pixels, without the lens distortion (the outline
        has it): centres ``(N, Pe, 2)``, semi-axes ``(N, Pe, 2)`` (major, minor) and the major
        axis' angle ``(N, Pe)`` (rad, from +u towards +v). The normalised ellipse mapped by
        ``K``'s affine part ``A``: centre ``A c + (c_u, c_v)``, shape ``A M A^T`` (the same ellipse
        as the conic ``K^-T C K^-1``'s)."""
        centre, M = self.ellipse
        K = np.asarray(self.intrinsics.K, float)
        A = K[:2, :2]
        centre = centre @ A.T + K[:2, 2]
        major, minor, angle = conics.ellipse_axes(A @ M @ A.T)
        return centre, stack([major, minor], -1), angle

    @cached_property
    def outline(self) -> Outline:
        """Every part's silhouette polygon (computed on first use)."""
        n, P, V = self.n, len(self.part_names), self.n_vertices
        uv, xy = np.empty((n, P, V, 2)), np.empty((n, P, V, 2))
        inv_z = np.empty((n, P, V))
        ci, ei = self.cone_idx, self.ellipsoid_idx
        if len(ci):
            c_loc, phi_c, delta, facing = self.cone_view
            a, b, L, k = self.cone_shape.T
            phi, rim, _ = cones.outline_angles(phi_c, delta, self.generators, facing, c_loc,
                                               L, k, (V - 4) // 2)
            XYZ = cones.rim_points(phi, rim, a, b, L, k, self.cone_R, self.cone_t)
            out = _image(self.intrinsics, XYZ, self.valid[:, ci])
            uv[:, ci], xy[:, ci], inv_z[:, ci] = out.uv, out.xy, out.inv_depth
        if len(ei):
            centre, M = self.ellipse
            _, bq, c = self.quadric
            out = _ellipse_outline(self.intrinsics, centre, M, bq, c, self.valid[:, ei], V)
            uv[:, ei], xy[:, ei], inv_z[:, ei] = out.uv, out.xy, out.inv_depth
        return Outline(uv, xy, inv_z, self.valid)


def project(body: BodyModel, pose: Pose, intr: Intrinsics, T_cam_ref: np.ndarray,
            n_vertices: int = 16) -> BodyView:
    """Every part of ``body`` at ``pose`` seen by a camera with intrinsics ``intr`` at
    ``T_cam_ref`` (4x4: reference-frame points -> camera frame, OpenCV axes), e.g.
    ``invert_transform(camera.T_base_cam)`` when the torso pose is in the robot's base frame.
    ``n_vertices`` = V >= 6, even, of the outlines (cones: 4 generator ends and ``V - 4``
    rim-arc points shared by the two rims)."""
    if n_vertices < 6 or n_vertices % 2:
        raise ValueError(f"project: n_vertices must be even and >= 6, got {n_vertices}")
    R_ref, p_ref = body.part_frames(pose)
    T = np.asarray(T_cam_ref, float)
    R = T[:3, :3] @ R_ref
    t = p_ref @ T[:3, :3].T + T[:3, 3]
    n, P = t.shape[:2]
    lay = body.layout
    ci, ei, shape = lay.cone_idx, lay.ellipsoid_idx, lay.cone_shape
    valid = np.empty((n, P), bool)

    # cones: contour generators and axes
    a, b, L, k = shape.T
    R_c, t_c = np.take(R, ci, axis=1), np.take(t, ci, axis=1)
    c_loc = -(t_c[..., None, :] @ R_c)[..., 0, :]
    phi_c, delta, exists, facing = cones.generator_angles(a, b, L, k, c_loc)
    valid[:, ci] = cones.in_front(R_c, t_c, a, b, L, k, Z_MIN)
    # the generators' ends: angles phi_c + delta, phi_c + delta, phi_c - delta, phi_c - delta
    # on rims 0, 1, 0, 1 (each generator's cosine and sine computed once)
    g = stack([phi_c + delta, phi_c - delta], -1)
    cos_sin = tuple(np.repeat(f(g), 2, axis=-1) for f in (np.cos, np.sin))
    XYZ = cones.rim_points(None, np.array([0, 1, 0, 1]), a, b, L, k, R_c, t_c, cos_sin)
    sides = _image(intr, XYZ, valid[:, ci]).uv.reshape(n, len(ci), 2, 2, 2)
    axis_xyz = stack([t_c, t_c + R_c[..., :, 2] * L[:, None]], axis=-2)

    # ellipsoids: quadrics and conics (Menezes eqs. 14-15)
    axes = lay.semi_axes
    R_e, t_e = np.take(R, ei, axis=1), np.take(t, ei, axis=1)
    A, bq, c = conics.ellipsoid_quadric(R_e, t_e, axes)
    C = conics.quadric_to_conic(A, bq, c)
    centre, M, ok = conics.conic_to_ellipse(C)
    valid[:, ei] = ok & (c > 0.0) & _ellipsoid_in_front(R_e, t_e, axes)

    return BodyView(body.part_names, intr, n_vertices, valid, ci, ei, R_c, t_c, shape, exists,
                    sides, axis_xyz, _pixels(intr, axis_xyz[..., :2] / axis_xyz[..., 2:]),
                    (A, bq, c), C, (centre, M), (c_loc, phi_c, delta, facing))
