"""Image features sampled on a projected body model, for the trackers' likelihoods.

* :func:`contour_points` -- ``n`` points per part spread uniformly (by arc length) along its
  silhouette, with outward unit normals and a visibility flag after hidden-part removal:
  Menezes et al.'s N_p model points of the shape cue (eqs. 2-5).
* :func:`limb_edges` -- Schmidt et al.'s edge cue (eqs. 1-2): ``M_E`` points on a limb's two
  boundary lines (the cone's contour generators), their normals and the limb's image angle.
* :func:`limb_ridges` -- the ridge cue (eqs. 3-4): ``M_R`` points along the limb's image axis,
  the limb's projected width there (px) and its depth (m), from which a tracker picks the
  Gaussian-pyramid level.
* :func:`limb_bands` -- the mean-colour cue (eqs. 5-7): ``B_l`` quadrilaterals tiling the limb
  along its length, optionally shrunk towards the axis.

Limb features are for the cone parts (``view.cone_idx``, in that order); their ``ok`` flag is
False where the part is invalid or seen end-on (no contour generators). Pixels everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from humimic.bodymodel.occlusion import hidden
from humimic.bodymodel.projection import BodyView, Outline
from humimic.maths.arrays import stack


@dataclass(frozen=True)
class ContourPoints:
    uv: np.ndarray
    """(N, P, n, 2) pixels."""
    normal: np.ndarray
    """(N, P, n, 2) outward unit normals (pixels)."""
    visible: np.ndarray
    """(N, P, n) bool: the part is valid and the point is not hidden by another part."""
    xy: np.ndarray
    """(N, P, n, 2) undistorted normalised coordinates."""
    inv_depth: np.ndarray
    """(N, P, n) 1 / depth (1/m)."""


def resample(outline: Outline, n: int) -> ContourPoints:
    """``n`` points per outline, uniformly spaced by arc length (pixels) round the closed
    polygon, starting half a step in; normals perpendicular to the polygon edge they lie on.
    ``xy`` and ``inv_depth`` are interpolated linearly with the same fraction (exact for a
    straight 3-D edge in ``xy`` and ``inv_depth``; the pixel fraction differs from it only by
    the lens distortion across one edge)."""
    N, P, V, _ = outline.uv.shape
    R = N * P
    # coordinate planes (R, V): numpy is slow on trailing axes of size 2
    u, v = outline.uv[..., 0].reshape(R, V), outline.uv[..., 1].reshape(R, V)
    valid = outline.valid.reshape(R)
    du, dv = np.roll(u, -1, axis=1) - u, np.roll(v, -1, axis=1) - v
    length = np.hypot(du, dv)
    cum = np.zeros((R, V + 1))
    np.cumsum(length, axis=1, out=cum[:, 1:])
    total = cum[:, -1:]
    # invalid (NaN) rows get evenly spaced dummies
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(valid[:, None], cum / total, np.linspace(0.0, 1.0, V + 1))
    target = (np.arange(n) + 0.5) / n
    # The edge each target falls on: edge e holds the targets in [unit_e, unit_e+1); the
    # number of targets below u is clip(ceil(u n - 1/2), 0, n).
    below = np.clip(np.ceil(unit * n - 0.5), 0, n).astype(np.intp)
    below[:, 0], below[:, -1] = 0, n
    idx = np.repeat(np.tile(np.arange(V), R), np.diff(below, axis=1).ravel())   # (R n,)
    rows = np.repeat(np.arange(R), n)
    fi = idx + rows * V                                                 # flat vertex index
    fn = np.where(idx + 1 == V, fi + 1 - V, fi + 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = ((np.tile(target, R) * np.repeat(total[:, 0], n) - np.take(cum, idx + rows * (V + 1)))
             / np.maximum(np.take(length, fi), 1e-12))

    def lerp1(a):
        a = a.ravel()
        a0 = np.take(a, fi)
        return (a0 + f * (np.take(a, fn) - a0)).reshape(N, P, n)

    area = np.sum(u * np.roll(v, -1, 1) - np.roll(u, -1, 1) * v, axis=1)
    sign = np.repeat(np.sign(area), n)
    nu, nv = np.take(dv, fi) * sign, -np.take(du, fi) * sign
    norm = np.maximum(np.hypot(nu, nv), 1e-12)
    xy = outline.xy
    visible = np.broadcast_to(outline.valid[..., None], (N, P, n)).copy()
    normal = np.stack([nu / norm, nv / norm], -1).reshape(N, P, n, 2)
    return ContourPoints(np.stack([lerp1(u), lerp1(v)], -1), normal, visible,
                         np.stack([lerp1(xy[..., 0]), lerp1(xy[..., 1])], -1),
                         lerp1(outline.inv_depth))


def contour_points(view: BodyView, n: int, occlusion: bool = True) -> ContourPoints:
    """``n`` contour points per part with normals; ``visible`` after hidden-part removal
    (``occlusion=False`` skips it, as Schmidt et al. do for speed)."""
    pts = resample(view.outline, n)
    if occlusion:
        pts.visible[hidden(view, pts.xy, pts.inv_depth)] = False
    return pts


def lerp(p0: np.ndarray, p1: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``p0 + f (p1 - p0)`` for points ``(..., D)`` and fractions ``f (M,)``: ``(..., M, D)``.

    One matrix product ``[p0 p1] @ [1 - f; f]``: numpy's broadcasting over a trailing axis of
    size 2 runs ~30x slower than this for the trackers' array shapes."""
    W = stack([1.0 - f, f])                                          # (2, M)
    lead, d = p0.shape[:-1], p0.shape[-1]
    P = stack([p0, p1], axis=-1).reshape(-1, 2)                     # (..., D) rows
    return (P @ W).reshape(*lead, d, len(f)).swapaxes(-1, -2)


def _ends(view: BodyView) -> tuple[np.ndarray, np.ndarray]:
    """Base and top ends ``(N, Pc, 2 sides, 2)`` of the cones' boundary lines (pixels)."""
    return view.sides_uv[:, :, :, 0], view.sides_uv[:, :, :, 1]


def _ok(view: BodyView) -> np.ndarray:
    return view.valid[:, view.cone_idx] & view.generators


@dataclass(frozen=True)
class LimbEdges:
    uv: np.ndarray
    """(N, Pc, M_E, 2) points, the first half on side 1, the rest on side 2 (pixels)."""
    normal: np.ndarray | None
    """(N, Pc, M_E, 2) outward unit normals of the boundary lines (None with
    ``normals=False``)."""
    angle: np.ndarray
    """(N, Pc) the limb's image angle (rad, atan2 of its axis from base to top, pixels)."""
    ok: np.ndarray
    """(N, Pc) bool."""


def limb_edges(view: BodyView, m_e: int, normals: bool = True) -> LimbEdges:
    """``m_e`` (even) points equally spaced on the limbs' two boundary lines (Schmidt eq. 1);
    ``normals=False`` skips the normals (Schmidt's cue needs only the limb's angle; the
    other fields are the same)."""
    if m_e < 2 or m_e % 2:
        raise ValueError(f"limb_edges: M_E must be even and >= 2, got {m_e}")
    base, top = _ends(view)                                           # (N, Pc, 2, 2)
    f = (np.arange(m_e // 2) + 0.5) / (m_e // 2)
    n, pc = base.shape[:2]
    uv = lerp(base, top, f).reshape(n, pc, m_e, 2)
    ax = view.axis_uv[:, :, 1] - view.axis_uv[:, :, 0]
    if not normals:
        return LimbEdges(uv, None, np.arctan2(ax[..., 1], ax[..., 0]), _ok(view))
    mid = 0.5 * (view.axis_uv[:, :, 0] + view.axis_uv[:, :, 1])
    d = top - base
    nrm = np.stack([d[..., 1], -d[..., 0]], -1)
    nrm /= np.maximum(np.hypot(nrm[..., 0], nrm[..., 1]), 1e-12)[..., None]
    away = np.sum(nrm * (base - mid[:, :, None]), axis=-1) < 0       # point it outwards
    nrm[away] *= -1.0
    normal = lerp(nrm, nrm, f).reshape(n, pc, m_e, 2)
    return LimbEdges(uv, normal, np.arctan2(ax[..., 1], ax[..., 0]), _ok(view))


@dataclass(frozen=True)
class LimbRidges:
    uv: np.ndarray
    """(N, Pc, M_R, 2) points on the limb's image axis (pixels)."""
    width: np.ndarray
    """(N, Pc, M_R) the limb's image width across its axis at each point (pixels)."""
    angle: np.ndarray
    """(N, Pc) image angle of the axis (rad)."""
    ok: np.ndarray
    """(N, Pc) bool."""
    inv_z: np.ndarray
    """(N, Pc, 2) 1 / depth of the axis ends (1/m)."""
    f: np.ndarray
    """(M_R,) the points' fractions along the axis."""

    @cached_property
    def depth(self) -> np.ndarray:
        """(N, Pc, M_R) depth of the axis points (m; perspective-correct interpolation of
        the ends', computed on first use)."""
        inv_z = self.inv_z
        return 1.0 / lerp(inv_z[..., :1], inv_z[..., 1:], self.f)[..., 0]


def limb_ridges(view: BodyView, m_r: int) -> LimbRidges:
    """``m_r`` points equally spaced along the limbs' image axes (Schmidt eq. 3), the limb's
    projected width there (interpolated between its widths at the two rims, measured across
    the axis) and the points' depth (perspective-correct interpolation of the ends')."""
    f = (np.arange(m_r) + 0.5) / m_r
    a0, a1 = view.axis_uv[:, :, 0], view.axis_uv[:, :, 1]
    ax = a1 - a0
    length = np.maximum(np.hypot(ax[..., 0], ax[..., 1]), 1e-12)
    base, top = _ends(view)
    # across-axis distance between the two boundary lines at the base and top rims
    across = stack([ax[..., 1], -ax[..., 0]], -1)[:, :, None] / length[..., None, None]
    w = np.abs(np.add.reduce((stack([base[:, :, 0], top[:, :, 0]], 2)
                       - stack([base[:, :, 1], top[:, :, 1]], 2)) * across, axis=-1))
    return LimbRidges(lerp(a0, a1, f), lerp(w[..., :1], w[..., 1:], f)[..., 0],
                      np.arctan2(ax[..., 1], ax[..., 0]), _ok(view),
                      1.0 / view.axis_xyz[..., 2], f)


def limb_bands(view: BodyView, bands: int, shrink: float = 0.0,
               limbs: np.ndarray | None = None) -> np.ndarray:
    """``(N, Pc, B, 4, 2)`` quadrilaterals (pixels) tiling each limb in ``bands`` equal
    slices from base to top, each pulled towards the axis by the fraction ``shrink`` of its
    half-width (Schmidt's B_l colour polygons; ``shrink > 0`` keeps them off the edges).
    ``limbs``: only these cone positions (axis 1 then has their length)."""
    if bands < 1 or not 0.0 <= shrink < 1.0:
        raise ValueError(f"limb_bands: bands >= 1 and 0 <= shrink < 1, got {bands}, {shrink}")
    base, top = _ends(view)
    if limbs is not None:
        base, top = base[:, limbs], top[:, limbs]
    s = lerp(base, top, np.arange(bands + 1) / bands)                 # (N, Pc, 2, B+1, 2)
    mid = 0.5 * (s[:, :, 0] + s[:, :, 1])
    s1 = mid + (1 - shrink) * (s[:, :, 0] - mid)
    s2 = mid + (1 - shrink) * (s[:, :, 1] - mid)
    return stack([s1[:, :, :-1], s1[:, :, 1:], s2[:, :, 1:], s2[:, :, :-1]], axis=3)
