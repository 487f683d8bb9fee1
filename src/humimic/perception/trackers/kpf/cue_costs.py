"""All of Schmidt et al.'s cue costs of N particles' limbs in one compiled pass, and eq. 10's
balanced sum of their Gaussians, compiled.

:mod:`humimic.perception.trackers.kpf.cues` states each cue's maths in numpy on feature points;
the likelihood first read them with one compiled kernel per cue (kept as the tests' reference,
``tests/_kpf_limb_cues.py``), then turned each kernel's responses into costs with numpy (masks
of invalid limbs, the colour distance of eq. 6, scatter into ``(N, parts)`` planes) and summed
eq. 10 over the cues with more numpy: at the paper's 150 particles numpy's per-call overhead of
those dozens of small operations cost as much as the kernels. :func:`cue_costs` does it all in
one loop over particles and parts, reading the maps through the same scalar arithmetic as those
kernels, in the same order (so the costs are bit-identical to theirs), and :func:`eq10_terms`
sums eq. 10. Costs (0 perfect):

* edge (eqs. 1-2), ridge (eqs. 3-4), skin (eq. 8): ``1 - f`` of the response ``f``, 1 where
  the limb is invalid (behind the camera, no contour generators; for skin: the ellipsoid);
* colour (eqs. 5-6): the mean over the limb's bands of ``||C_t - C_ref||``, 0 before the
  limb's first adaptation (no reference), 1 where the limb is invalid;
* NaN where the cue is not configured on the part.
"""

from __future__ import annotations

import numpy as np

from humimic.maths.jit import njit
from humimic.perception.trackers.kpf.cues import _DISC, _QUAD_GRID, RIDGE_WIDTH_PX

#: Cost planes' order (``likelihood.CUE_NAMES``).
EDGE, RIDGE, COLOUR, SKIN = 0, 1, 2, 3


@njit
def _axis_angle(axis, n, j):
    """The image angle of limb ``j``'s axis of particle ``n`` (``axis (N, Pc, 2 ends, 2)``)."""
    return np.arctan2(axis[n, j, 1, 1] - axis[n, j, 0, 1], axis[n, j, 1, 0] - axis[n, j, 0, 0])


@njit
def _fractions(m):
    """``(m, 2)``: ``f = (k + 1/2) / m`` and ``1 - f``, the points' places along a segment."""
    out = np.empty((m, 2))
    for k in range(m):
        out[k, 0] = (k + 0.5) / m
        out[k, 1] = 1.0 - out[k, 0]
    return out


@njit
def _edge(sides, axis, n, j, grad, u0, v0, fe):
    """``limb_cues._edge_kernel``'s response of limb ``j`` of particle ``n`` (``fe``:
    :func:`_fractions` of ``M_E / 2``)."""
    half = fe.shape[0]
    w, h = float(grad.shape[1]), float(grad.shape[0])
    a = _axis_angle(axis, n, j)
    c, s = np.cos(a), np.sin(a)
    acc = 0.0
    for side in range(2):
        bu, bv = sides[n, j, side, 0, 0], sides[n, j, side, 0, 1]
        tu, tv = sides[n, j, side, 1, 0], sides[n, j, side, 1, 1]
        for k in range(half):
            f, g = fe[k, 0], fe[k, 1]
            x = np.rint(bu * g + tu * f) - u0            # limb_cues._pixel, inlined
            y = np.rint(bv * g + tv * f) - v0
            if x >= 0.0 and y >= 0.0 and x < w and y < h:     # NaN: False
                yi, xi = int(y), int(x)
                acc += abs(float(grad[yi, xi, 1]) * c - float(grad[yi, xi, 0]) * s)
            else:                                        # off the maps: both read 0
                acc += abs(0.0 * c - 0.0 * s)
    return acc / (2 * half)


@njit
def _ridge(sides, axis, n, j, ridge, shapes, rows, u0, v0, fr):
    """``limb_cues._ridge_kernel``'s response of limb ``j`` of particle ``n`` (``fr``:
    :func:`_fractions` of ``M_R``)."""
    levels, m_r = shapes.shape[0], fr.shape[0]
    au, av = axis[n, j, 0, 0], axis[n, j, 0, 1]
    du, dv = axis[n, j, 1, 0] - au, axis[n, j, 1, 1] - av
    a = np.arctan2(dv, du)
    length = max(np.hypot(du, dv), 1e-12)
    cu, cv = dv / length, -du / length                  # across the axis
    w0 = abs((sides[n, j, 0, 0, 0] - sides[n, j, 1, 0, 0]) * cu
             + (sides[n, j, 0, 0, 1] - sides[n, j, 1, 0, 1]) * cv)
    w1 = abs((sides[n, j, 0, 1, 0] - sides[n, j, 1, 1, 0]) * cu
             + (sides[n, j, 0, 1, 1] - sides[n, j, 1, 1, 1]) * cv)
    width = 0.0
    for k in range(m_r):
        width += w0 * fr[k, 1] + w1 * fr[k, 0]
    width /= m_r
    if not width >= 1e-3:                               # fmax: NaN -> 1e-3
        width = 1e-3
    mu = int(min(max(np.rint(np.log2(width / RIDGE_WIDTH_PX)), 0.0), levels - 1.0))
    scale = 0.5 ** mu
    h_mu, w_mu, r0 = float(shapes[mu, 0]), float(shapes[mu, 1]), rows[mu]
    c2, s2 = np.cos(2.0 * a), np.sin(2.0 * a)
    tu, tv = au + du, av + dv
    ou, ov = u0 * scale, v0 * scale
    acc = 0.0
    for k in range(m_r):
        f, g = fr[k, 0], fr[k, 1]
        x = np.rint((au * g + tu * f) * scale) - ou
        y = np.rint((av * g + tv * f) * scale) - ov
        if not (x >= 0.0 and y >= 0.0 and x < w_mu and y < h_mu):
            continue                                    # off the level (or NaN): 0
        xi, yi = int(x), int(y) + r0
        t = float(ridge[yi, xi, 2])
        p = ridge[yi, xi, 0] * c2 + ridge[yi, xi, 1] * s2
        acc += abs(t - p) - abs(t + p)
    return acc / m_r


@njit
def _bands(sides, n, j, bands, keep, rgb, u0, v0, wts, out, corner, p):
    """``limb_cues._band_kernel``: the mean RGB of limb ``j``'s ``bands`` quadrilaterals into
    ``out (bands, 3)`` (``wts (M_C, 4)`` the grid's bilinear weights; ``corner (4, 2)``,
    ``p (2, 2)`` scratch)."""
    m = wts.shape[0]
    w, h = float(rgb.shape[1]), float(rgb.shape[0])
    for b in range(bands):
        for e in range(2):                              # slice ends b, b + 1 along the limb
            f = (b + e) / bands
            for side in range(2):
                for d in range(2):
                    p[side, d] = (sides[n, j, side, 0, d] * (1.0 - f)
                                  + sides[n, j, side, 1, d] * f)
            for d in range(2):
                mid = 0.5 * (p[0, d] + p[1, d])
                corner[e, d] = mid + keep * (p[0, d] - mid)       # side 1: 0 base, 1 top
                corner[3 - e, d] = mid + keep * (p[1, d] - mid)   # side 2: 2 top, 3 base
        r = g = bl = 0.0
        for k in range(m):
            u = v = 0.0
            for c in range(4):
                u += wts[k, c] * corner[c, 0]
                v += wts[k, c] * corner[c, 1]
            x = np.rint(u) - u0
            y = np.rint(v) - v0
            if x >= 0.0 and y >= 0.0 and x < w and y < h:
                yi, xi = int(y), int(x)
                r += float(rgb[yi, xi, 0])
                g += float(rgb[yi, xi, 1])
                bl += float(rgb[yi, xi, 2])
            else:
                r, g, bl = r + 0.0, g + 0.0, bl + 0.0
        out[b, 0], out[b, 1], out[b, 2] = r / m, g / m, bl / m


@njit
def _skin(centre, axes, angle, n, e, skin, u0, v0, disc):
    """``limb_cues._skin_kernel``: the skin fraction of ellipse ``e`` of particle ``n``."""
    c, s = np.cos(angle[n, e]), np.sin(angle[n, e])
    w, h = float(skin.shape[1]), float(skin.shape[0])
    acc = 0.0
    for k in range(disc.shape[0]):
        x, y = disc[k, 0] * axes[n, e, 0], disc[k, 1] * axes[n, e, 1]
        px = np.rint(centre[n, e, 0] + c * x - s * y) - u0
        py = np.rint(centre[n, e, 1] + s * x + c * y) - v0
        if px >= 0.0 and py >= 0.0 and px < w and py < h:
            acc += float(skin[int(py), int(px), 0])
        else:
            acc += 0.0
    return acc / disc.shape[0]


@njit
def _costs_kernel(sides, axis, generators, valid, cone_idx, ell_idx, centre, axes, angle,
                  limb_cue, limb_bands, refs, has_ref, ell_skin, grad, ridge, shapes, rows,
                  rgb, skin, u0, v0, m_e, m_r, keep, grid, disc, n_parts):
    n_p, n_c, n_e = sides.shape[0], sides.shape[1], centre.shape[1]
    cost = np.full((4, n_p, n_parts), np.nan)
    colours = np.zeros((n_p, n_c, refs.shape[1], 3))
    corner, scratch = np.empty((4, 2)), np.empty((2, 2))
    fe, fr = _fractions(m_e // 2), _fractions(m_r)
    wts = np.empty((grid.shape[0], 4))
    for k in range(grid.shape[0]):
        al, ac = grid[k, 0], grid[k, 1]
        wts[k, 0], wts[k, 1] = (1 - al) * (1 - ac), al * (1 - ac)
        wts[k, 2], wts[k, 3] = al * ac, (1 - al) * ac
    for n in range(n_p):
        for j in range(n_c):
            col = cone_idx[j]
            ok = valid[n, col] and generators[n, j]
            if limb_cue[j, EDGE]:
                f = _edge(sides, axis, n, j, grad, u0, v0, fe) if ok else 0.0
                cost[EDGE, n, col] = 1.0 - f
            if limb_cue[j, RIDGE]:
                f = _ridge(sides, axis, n, j, ridge, shapes, rows, u0, v0, fr) if ok else 0.0
                cost[RIDGE, n, col] = 1.0 - f
            b = limb_bands[j]
            if b > 0:                                   # band colours even where invalid
                _bands(sides, n, j, b, keep, rgb, u0, v0, wts, colours[n, j], corner, scratch)
                if not ok:
                    cost[COLOUR, n, col] = 1.0
                elif has_ref[j]:                        # Schmidt eq. 6
                    acc = 0.0
                    for k in range(b):
                        r = colours[n, j, k, 0] - refs[j, k, 0]
                        g = colours[n, j, k, 1] - refs[j, k, 1]
                        bl = colours[n, j, k, 2] - refs[j, k, 2]
                        acc += np.sqrt(r * r + g * g + bl * bl)
                    cost[COLOUR, n, col] = acc / b
                else:                                   # before the first adaptation
                    cost[COLOUR, n, col] = 0.0
        for e in range(n_e):
            if ell_skin[e]:
                col = ell_idx[e]
                f = _skin(centre, axes, angle, n, e, skin, u0, v0, disc) if valid[n, col] \
                    else 0.0
                cost[SKIN, n, col] = 1.0 - f
    return cost, colours


def cue_costs(maps, view, limb_cue: np.ndarray, limb_bands: np.ndarray, refs: np.ndarray,
              has_ref: np.ndarray, ell_skin: np.ndarray, n_parts: int, m_e: int, m_r: int,
              shrink: float) -> tuple[np.ndarray, np.ndarray]:
    """Schmidt eqs. 1-8 as costs of every configured (cue, part) of the particles of ``view``
    (a :class:`~humimic.bodymodel.limb_view.LimbView`) on ``maps``
    (:class:`~humimic.perception.trackers.kpf.cues.CueMaps`): ``(cost (4, N, n_parts),
    colours (N, cones, B_max, 3))``, the cost planes in :data:`EDGE`, :data:`RIDGE`,
    :data:`COLOUR`, :data:`SKIN` order (NaN where the cue is not configured), the cones'
    mean band colours (zeros past their ``limb_bands`` and on cones without the colour cue).
    Per cone (position among ``view.cone_idx``): ``limb_cue (cones, 2)`` bool edge / ridge,
    ``limb_bands (cones,)`` colour bands (0: no colour cue), ``refs (cones, B_max, 3)`` the
    adapted reference colours where ``has_ref (cones,)``; per ellipsoid ``ell_skin`` bool;
    ``m_e`` (even), ``m_r`` the edge and ridge points, ``shrink`` the bands' shrink towards
    the axis."""
    u0, v0 = maps.origin
    skin = maps.skin[..., None] if maps.skin.ndim == 2 else maps.skin
    centre, axes, angle = view.ellipses
    return _costs_kernel(
        view.sides_uv, view.axis_uv, view.generators, view.valid,
        np.ascontiguousarray(view.cone_idx, np.intp),
        np.ascontiguousarray(view.ellipsoid_idx, np.intp), centre, axes, angle, limb_cue,
        limb_bands, refs, has_ref, ell_skin, maps.gradient, maps.ridge,
        np.ascontiguousarray(maps.level_shapes, np.intp),
        np.ascontiguousarray(maps.level_rows, np.intp), maps.rgb, skin, float(u0), float(v0),
        int(m_e), int(m_r), 1.0 - float(shrink), _QUAD_GRID, _DISC, int(n_parts))


@njit
def _eq10_kernel(cost, coef, used, any_used):
    n_c, n_p, n_parts = cost.shape
    out = np.empty((n_p, n_parts))
    for n in range(n_p):
        for p in range(n_parts):
            total = 0.0
            for c in range(n_c):
                if any_used[c]:
                    e = cost[c, n, p] if used[c, p] else 0.0
                    total = total - (e * e) * coef[c, p]
            out[n, p] = total
    return out


def eq10_coefficients(balance: np.ndarray, sigma) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 10's per (cue, part) factors ``1/N_l / (2 sigma_c^2)`` of ``balance (cues, parts)``
    (``1/N_l`` where the cue is used on the part, 0 elsewhere) and ``sigma (cues,)``, and the
    (cue, part) pairs used: :func:`eq10_terms`' ``coef``, ``used``."""
    balance = np.asarray(balance, float)
    coef = np.stack([balance[c] / (2.0 * float(sigma[c]) ** 2) for c in range(len(balance))])
    return coef, balance != 0.0


def eq10_terms(cost: np.ndarray, coef: np.ndarray, used: np.ndarray) -> np.ndarray:
    """Schmidt eqs. 9-10 per part ``l``: ``1/N_l sum_c -e_{c,l}^2 / (2 sigma_c^2)``,
    ``(N, parts)``, of costs ``cost (cues, N, parts)`` read where ``used (cues, parts)``,
    ``coef`` from :func:`eq10_coefficients`; summed over the cues in their order (a cue used
    on no part left out), as ``sum_c`` in numpy would."""
    return _eq10_kernel(np.ascontiguousarray(cost, float), coef, used, used.any(axis=1))
