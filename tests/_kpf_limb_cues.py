"""Test reference: Schmidt et al.'s limb cues (sec. 4) read straight off a projected body model,
one compiled kernel per cue -- the likelihood's implementation before the one-pass
:mod:`~humimic.perception.trackers.kpf.cue_costs` (the same arithmetic; ``test_kpf_cue_costs``
compares the two bit for bit, ``test_kpf_limb_cues`` these kernels with the numpy path). The
same responses as the feature points of :mod:`humimic.bodymodel.features` (``limb_edges``,
``limb_ridges``, ``limb_bands``) sampled by :mod:`humimic.perception.trackers.kpf.cues`
(``edge_response``, ``ridge_response``, ``band_colours``, ``skin_response``; they state the
maths and are the reference these kernels are tested against), fused into one loop per particle
and limb: no feature-point arrays, no ``cv2.remap`` map, and numpy's per-call overhead (which
dominated at the paper's 150 particles) paid once per cue instead of once per operation. Points
are placed as there (equally spaced by ``(k + 1/2) / M`` along the contour generators / the
image axis; the colour bands' 3 x 3 bilinear grid; the skin ellipse's centre and two rings) and
read at their nearest pixel (``np.rint``, half to even; 0 off the maps and at NaN points). Sums
are in float64 (the numpy path sums float32), so responses agree to ~1e-6.

Inputs are :class:`~humimic.bodymodel.projection.BodyView` fields: ``sides`` = ``sides_uv``
``(N, Pc, 2 sides, 2 ends, 2)``, ``axis`` = ``axis_uv`` ``(N, Pc, 2 ends, 2)``; ``limbs``
selects cone positions, outputs are ``(N, len(limbs))``.
"""

from __future__ import annotations

import numpy as np

from humimic.maths.jit import njit
from humimic.perception.trackers.kpf.cue_costs import _axis_angle
from humimic.perception.trackers.kpf.cues import _DISC, _QUAD_GRID, RIDGE_WIDTH_PX, CueMaps


@njit
def _pixel(img, u, v, u0, v0, ch):
    """``img[rint(v) - v0, rint(u) - u0, ch]``, 0 off the image or at NaN (``cues.sample``)."""
    x = np.rint(u) - u0
    y = np.rint(v) - v0
    if not (x >= 0.0 and y >= 0.0 and x < img.shape[1] and y < img.shape[0]):   # NaN: False
        return 0.0
    return float(img[int(y), int(x), ch])


@njit
def _edge_kernel(sides, axis, limbs, grad, u0, v0, m_e):
    """Schmidt eqs. 1-2 (``edge_response`` at ``limb_edges``' points)."""
    n_p, half = sides.shape[0], m_e // 2
    out = np.zeros((n_p, len(limbs)))
    for n in range(n_p):
        for i in range(len(limbs)):
            j = limbs[i]
            a = _axis_angle(axis, n, j)
            c, s = np.cos(a), np.sin(a)
            acc = 0.0
            for side in range(2):
                bu, bv = sides[n, j, side, 0, 0], sides[n, j, side, 0, 1]
                tu, tv = sides[n, j, side, 1, 0], sides[n, j, side, 1, 1]
                for k in range(half):
                    f = (k + 0.5) / half
                    u, v = bu * (1.0 - f) + tu * f, bv * (1.0 - f) + tv * f
                    acc += abs(_pixel(grad, u, v, u0, v0, 1) * c
                               - _pixel(grad, u, v, u0, v0, 0) * s)
            out[n, i] = acc / (2 * half)
    return out


@njit
def _ridge_kernel(sides, axis, limbs, ridge, shapes, rows, u0, v0, m_r):
    """Schmidt eqs. 3-4 (``ridge_response`` at ``limb_ridges``' points and mean width)."""
    n_p, levels = sides.shape[0], shapes.shape[0]
    out = np.zeros((n_p, len(limbs)))
    for n in range(n_p):
        for i in range(len(limbs)):
            j = limbs[i]
            au, av = axis[n, j, 0, 0], axis[n, j, 0, 1]
            du, dv = axis[n, j, 1, 0] - au, axis[n, j, 1, 1] - av
            a = np.arctan2(dv, du)
            length = max(np.hypot(du, dv), 1e-12)
            cu, cv = dv / length, -du / length          # across the axis
            w = np.empty(2)
            for end in range(2):                        # width at the base / top rim
                w[end] = abs((sides[n, j, 0, end, 0] - sides[n, j, 1, end, 0]) * cu
                             + (sides[n, j, 0, end, 1] - sides[n, j, 1, end, 1]) * cv)
            width = 0.0
            for k in range(m_r):
                f = (k + 0.5) / m_r
                width += w[0] * (1.0 - f) + w[1] * f
            width /= m_r
            if not width >= 1e-3:                       # fmax: NaN -> 1e-3
                width = 1e-3
            mu = int(min(max(np.rint(np.log2(width / RIDGE_WIDTH_PX)), 0.0), levels - 1.0))
            scale = 0.5 ** mu
            h_mu, w_mu, r0 = shapes[mu, 0], shapes[mu, 1], rows[mu]
            c2, s2 = np.cos(2.0 * a), np.sin(2.0 * a)
            acc = 0.0
            for k in range(m_r):
                f = (k + 0.5) / m_r
                x = np.rint((au * (1.0 - f) + (au + du) * f) * scale) - u0 * scale
                y = np.rint((av * (1.0 - f) + (av + dv) * f) * scale) - v0 * scale
                if not (x >= 0.0 and y >= 0.0 and x < w_mu and y < h_mu):
                    continue                            # off the level (or NaN): 0
                xi, yi = int(x), int(y) + r0
                t = float(ridge[yi, xi, 2])
                p = ridge[yi, xi, 0] * c2 + ridge[yi, xi, 1] * s2
                acc += abs(t - p) - abs(t + p)
            out[n, i] = acc / m_r
    return out


@njit
def _band_kernel(sides, limbs, bands, shrink, rgb, u0, v0, grid):
    """Mean RGB of each limb's ``bands`` quadrilaterals (``band_colours`` of ``limb_bands``):
    ``(N, len(limbs), bands, 3)``."""
    n_p = sides.shape[0]
    out = np.zeros((n_p, len(limbs), bands, 3))
    keep = 1.0 - shrink
    corner, p = np.empty((4, 2)), np.empty((2, 2))
    for n in range(n_p):
        for i in range(len(limbs)):
            j = limbs[i]
            for b in range(bands):
                for e in range(2):                      # slice ends b, b + 1 along the limb
                    f = (b + e) / bands
                    for side in range(2):
                        for d in range(2):
                            p[side, d] = (sides[n, j, side, 0, d] * (1.0 - f)
                                          + sides[n, j, side, 1, d] * f)
                    for d in range(2):
                        mid = 0.5 * (p[0, d] + p[1, d])
                        corner[e, d] = mid + keep * (p[0, d] - mid)       # side 1: 0 base, 1 top
                        corner[3 - e, d] = mid + keep * (p[1, d] - mid)   # side 2: 2 top, 3 base
                for g in range(grid.shape[0]):
                    al, ac = grid[g, 0], grid[g, 1]
                    wts = ((1 - al) * (1 - ac), al * (1 - ac), al * ac, (1 - al) * ac)
                    u = v = 0.0
                    for c in range(4):
                        u += wts[c] * corner[c, 0]
                        v += wts[c] * corner[c, 1]
                    for ch in range(3):
                        out[n, i, b, ch] += _pixel(rgb, u, v, u0, v0, ch)
    return out / grid.shape[0]


@njit
def _skin_kernel(centre, axes, angle, skin, u0, v0, disc):
    """Schmidt eq. 8 (``skin_response``): ``(N, E)`` skin fraction of the ellipses' points."""
    n_p, n_e = centre.shape[0], centre.shape[1]
    out = np.zeros((n_p, n_e))
    for n in range(n_p):
        for e in range(n_e):
            c, s = np.cos(angle[n, e]), np.sin(angle[n, e])
            acc = 0.0
            for k in range(disc.shape[0]):
                x, y = disc[k, 0] * axes[n, e, 0], disc[k, 1] * axes[n, e, 1]
                acc += _pixel(skin, centre[n, e, 0] + c * x - s * y,
                              centre[n, e, 1] + s * x + c * y, u0, v0, 0)
            out[n, e] = acc / disc.shape[0]
    return out


def _idx(limbs) -> np.ndarray:
    return np.ascontiguousarray(limbs, np.intp)


def edge_responses(maps: CueMaps, sides: np.ndarray, axis: np.ndarray, limbs, m_e: int
                   ) -> np.ndarray:
    """Schmidt eqs. 1-2: mean ``|g_v cos a - g_u sin a|`` over ``m_e`` (even) points on the
    limbs' two contour generators, ``a`` the image axis' angle: ``(N, len(limbs))``."""
    u0, v0 = maps.origin
    return _edge_kernel(np.ascontiguousarray(sides), np.ascontiguousarray(axis), _idx(limbs),
                        maps.gradient, float(u0), float(v0), int(m_e))


def ridge_responses(maps: CueMaps, sides: np.ndarray, axis: np.ndarray, limbs, m_r: int
                    ) -> np.ndarray:
    """Schmidt eqs. 3-4: mean ridge response over ``m_r`` points on the limbs' image axes at
    the pyramid level of their mean width: ``(N, len(limbs))``."""
    u0, v0 = maps.origin
    return _ridge_kernel(np.ascontiguousarray(sides), np.ascontiguousarray(axis), _idx(limbs),
                         maps.ridge, np.ascontiguousarray(maps.level_shapes, np.intp),
                         np.ascontiguousarray(maps.level_rows, np.intp), float(u0), float(v0),
                         int(m_r))


def band_colours(maps: CueMaps, sides: np.ndarray, limbs, bands: int, shrink: float
                 ) -> np.ndarray:
    """Schmidt eq. 5: mean RGB of each limb's ``bands`` colour polygons (shrunk towards the
    axis by ``shrink``): ``(N, len(limbs), bands, 3)``."""
    u0, v0 = maps.origin
    return _band_kernel(np.ascontiguousarray(sides), _idx(limbs), int(bands), float(shrink),
                        maps.rgb, float(u0), float(v0), _QUAD_GRID)


def skin_fractions(maps: CueMaps, centre: np.ndarray, axes: np.ndarray, angle: np.ndarray
                   ) -> np.ndarray:
    """Schmidt eq. 8: skin fraction of the sample points of image ellipses (centres
    ``(N, E, 2)``, semi-axes ``(N, E, 2)`` major/minor, major-axis angles ``(N, E)``)."""
    u0, v0 = maps.origin
    skin = maps.skin[..., None] if maps.skin.ndim == 2 else maps.skin
    return _skin_kernel(np.ascontiguousarray(centre, float), np.ascontiguousarray(axes, float),
                        np.ascontiguousarray(angle, float), skin, float(u0), float(v0), _DISC)
