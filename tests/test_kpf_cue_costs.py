"""The one-pass compiled cue costs (:mod:`humimic.perception.trackers.kpf.cue_costs`) and the
fused cue-map normalisation against the implementation they replaced, bit for bit: the costs
of the per-cue kernels of ``_kpf_limb_cues`` (the likelihood's before; themselves tested
against the feature-point numpy path in ``test_kpf_limb_cues.py``) masked, scattered and
combined with numpy as the likelihood did (:func:`reference`), eq. 10 as numpy's sum over the
cues, the maps' normalisation with ``strongest_channel`` and ``_norm_factor``
(:func:`reference_maps`), the sample box with numpy's reductions. Synthetic frames and poses
(``_kpf_synth``): particles spread widely (limbs off the image, across its borders, seen
end-on, behind the camera), maps of the whole image and of regions, every cue on every limb
type, none on some, before and after the colour references are adapted."""

from __future__ import annotations

import _kpf_limb_cues as K
import cv2
import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

from humimic.bodymodel.limb_view import limb_view
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf import cues as C
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.cue_costs import eq10_coefficients, eq10_terms
from humimic.perception.trackers.kpf.frame_cues import FrameCues, sample_box
from humimic.perception.trackers.kpf.likelihood import BAND_SHRINK, CUE_NAMES, Likelihood
from humimic.perception.trackers.kpf.tracker import kpf_body

ALL_CUES = {"torso": ["edge", "ridge", "colour"], "upper_arm": ["edge", "ridge", "colour"],
            "forearm": ["edge", "ridge", "colour"], "hand": ["skin"], "head": ["skin"]}
FEW_CUES = {"torso": ["colour"], "upper_arm": ["ridge"], "forearm": [], "hand": [],
            "head": ["skin"]}


def reference(lik: Likelihood, q, maps, T):
    """The likelihood's costs, colours and eq.-10 terms as main computed them: one kernel per
    cue, numpy masks and scatters, ``colour_response``, numpy's eq. 10."""
    cfg, n = lik.cfg, len(q)
    view = limb_view(lik.body, lik.body.forward(q), lik.intr, T)
    planes = np.full((4, n, len(lik.parts)), np.nan)
    cost = dict(zip(CUE_NAMES, planes, strict=True))
    ok = view.valid[:, view.cone_idx] & view.generators
    cols = np.asarray(view.cone_idx)
    for c, fn, m in (("edge", K.edge_responses, cfg.edge_points),
                     ("ridge", K.ridge_responses, cfg.ridge_points)):
        js = np.array([j for j, p in enumerate(lik.limbs) if c in lik.use[p]], np.intp)
        if len(js):
            f = fn(maps, view.sides_uv, view.axis_uv, js, m)
            cost[c][:, cols[js]] = 1.0 - np.where(ok[:, js], f, 0.0)
    colours, sets = {}, {}
    for j, p in enumerate(lik.limbs):
        if "colour" in lik.use[p]:
            sets.setdefault(lik.bands[p], []).append((j, p))
    for b, members in sets.items():
        js = np.array([j for j, _ in members], np.intp)
        got = K.band_colours(maps, view.sides_uv, js, b, BAND_SHRINK)
        f = np.zeros((n, len(js)))
        for k, (_, p) in enumerate(members):
            colours[p] = got[:, k]
            if p in lik.references:
                f[:, k] = C.colour_response(got[:, k:k + 1], lik.references[p][None])[:, 0]
        cost["colour"][:, cols[js]] = np.where(ok[:, js], f, 1.0)
    ell = [lik.parts[i] for i in view.ellipsoid_idx]
    js = np.array([j for j, p in enumerate(ell) if "skin" in lik.use[p]], np.intp)
    if len(js):
        centre, axes, angle = view.ellipses
        f = K.skin_fractions(maps, centre[:, js], axes[:, js], angle[:, js])
        cost["skin"][:, np.asarray(view.ellipsoid_idx)[js]] = 1.0 - np.where(
            view.valid[:, np.asarray(view.ellipsoid_idx)[js]], f, 0.0)
    return cost, colours, reference_terms(lik, cost)


def reference_terms(lik: Likelihood, cost):
    sig = lik.sigmas(cost)
    total = 0.0
    for c, e in cost.items():
        if lik.used[c].any():
            e = np.where(lik.used[c], e, 0.0)
            total = total - (e * e) * (lik.balance[c] / (2.0 * sig[c] ** 2))
    return total


@pytest.fixture(scope="module")
def scene():
    body, T, q0 = kpf_body(), camera(), static_pose()
    img = painted_person(body, q0, T)
    rng = np.random.default_rng(11)
    noise = rng.normal(0.0, 12.0, img.shape)
    img = np.clip(cv2.GaussianBlur(img, (0, 0), 1.0) + noise, 0, 255).astype(np.uint8)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    D = np.array(KpfConfig().D())
    q = body.free_limits.clamp(q0 + rng.uniform(-2.0, 2.0, (120, 14)) * D)
    q[:20, 1] += np.linspace(-1.2, 1.2, 20)          # across the image's left / right borders
    q[20:30, 2] += np.linspace(0.6, 1.4, 10)         # over the top border
    q[30:34, 0] += 2.3                               # behind the camera: invalid parts
    q[34] = q0                                       # the painted pose itself
    return body, T, img, lut, q


def same(a, b) -> bool:
    return np.asarray(a).shape == np.asarray(b).shape and np.array_equal(a, b, equal_nan=True)


def check(lik, q, maps, T, frame=None):
    want_cost, want_colours, want_terms = reference(lik, q, maps, T)
    ev = lik.evaluate(q, maps if frame is None else frame, T)
    assert all(same(ev.cost[c], want_cost[c]) for c in CUE_NAMES)
    assert ev.colours.keys() == want_colours.keys()
    assert all(same(ev.colours[p], want_colours[p]) for p in want_colours)
    assert same(ev.terms, want_terms)
    return ev


@pytest.mark.parametrize("cues", [None, ALL_CUES, FEW_CUES], ids=["paper", "all", "few"])
def test_costs_equal_the_per_cue_kernels_and_numpy(scene, cues):
    body, T, img, lut, q = scene
    cfg = KpfConfig() if cues is None else KpfConfig(cues=cues)
    lik = Likelihood(body, INTRINSICS, cfg)
    maps = C.cue_maps(img, lut)
    ev = check(lik, q, maps, T)                     # no references yet: colour cost 0
    lik.adapt({p: c[34] for p, c in ev.colours.items()})
    ev = check(lik, q, maps, T)
    used = [c for c in CUE_NAMES if lik.used[c].any()]
    assert all(np.isfinite(ev.cost[c][:, lik.used[c]]).all() for c in used)
    assert all(np.isnan(ev.cost[c][:, ~lik.used[c]]).all() for c in CUE_NAMES)
    spread = [np.ptp(ev.cost[c][:, lik.used[c]]) for c in used]
    assert min(spread) > 0.1                        # the cues see the particles differ


def test_costs_with_only_some_limbs_adapted(scene):
    body, T, img, lut, q = scene
    lik = Likelihood(body, INTRINSICS, KpfConfig(cues=ALL_CUES))
    maps = C.cue_maps(img, lut)
    colours = lik.evaluate(q[34:35], maps, T).colours
    first = sorted(colours)[0]
    lik.adapt({first: colours[first][0]})           # the torso only: the others cost 0
    ev = check(lik, q, maps, T)
    assert ev.cost["colour"][:, lik.parts.index(first)].max() > 0.0


@pytest.mark.parametrize("colour_gradients", [False, True])
def test_costs_on_region_maps(scene, colour_gradients):
    """Maps of an image region (an origin), as ``FrameCues`` computes them: the costs of the
    maps the evaluation used."""
    body, T, img, lut, q = scene
    lik = Likelihood(body, INTRINSICS, KpfConfig(colour_gradients=colour_gradients))
    frame = FrameCues(img, lut, colour_gradients=colour_gradients)
    lik.adapt({p: c[0] for p, c in lik.evaluate(q[34:35], frame, T).colours.items()})
    sub = q[34:80]
    frame = FrameCues(img, lut, colour_gradients=colour_gradients)
    check(lik, sub, frame.covering(*sample_box(limb_view(body, body.forward(sub),
                                                         INTRINSICS, T))), T, frame)
    assert frame.region != (0, 0, img.shape[1], img.shape[0])
    assert frame.maps.origin != (0, 0)


def test_costs_where_the_maps_hold_none_of_the_points(scene):
    """Maps of a small region far from the particles: every point reads 0 (responses 0, band
    colours black)."""
    body, T, img, lut, q = scene
    lik = Likelihood(body, INTRINSICS, KpfConfig())
    maps = C.cue_maps(img, lut, region=(296, 216, 320, 240))
    ev = check(lik, q[34:60], maps, T)
    assert np.all(ev.cost["edge"][:, lik.used["edge"]] == 1.0)
    assert all(np.all(c == 0.0) for c in ev.colours.values())


def test_eq10_terms_equal_numpys_sum_with_spread_sigmas(scene):
    body, T, img, lut, q = scene
    lik = Likelihood(body, INTRINSICS, KpfConfig(sigma_from_spread=True, cues=ALL_CUES))
    rng = np.random.default_rng(5)
    cost = {c: np.where(lik.used[c], rng.uniform(0, 1, (40, len(lik.parts))), np.nan)
            for c in CUE_NAMES}
    sig = lik.sigmas(cost)
    assert sig["edge"] > lik.floor["edge"]          # from the spread, not the floor
    planes = np.stack([cost[c] for c in CUE_NAMES])
    got = eq10_terms(planes, *eq10_coefficients(lik.balance_planes, [sig[c] for c in CUE_NAMES]))
    assert same(got, reference_terms(lik, cost))
    assert same(lik.combine(cost), got)


def test_log_likelihood_with_the_skin_ring(scene):
    """The whole evaluation with the hands' skin surround (added to the compiled terms)."""
    from humimic.perception.trackers.kpf.skin_ring import ring_log_term, ring_skin

    body, T, img, lut, q = scene
    lik = Likelihood(body, INTRINSICS, KpfConfig(skin_ring=1.5))
    maps = C.cue_maps(img, lut)
    _, _, terms = reference(lik, q, maps, T)
    view = limb_view(body, body.forward(q), INTRINSICS, T)
    j, idx = lik.hand_js, np.asarray(view.ellipsoid_idx)
    centre, axes, angle = view.ellipses
    s = ring_skin(maps, centre[:, j], axes[:, j], angle[:, j], 1.5)
    terms[:, idx[j]] += ring_log_term(np.where(view.valid[:, idx[j]], s, 0.0),
                                      lik.floor["skin"])
    assert same(lik.evaluate(q, maps, T).log_lik, terms.sum(axis=1))


def reference_maps(img, lut, region, colour_gradients, k_edge=0.15, k_ridge=0.05):
    """``cue_maps``' gradient and ridge maps normalised with numpy (main's code)."""
    if region is not None:
        u0, v0, u1, v1 = region
        img = img[v0:v1, u0:u1]
    grey = (img.astype(np.float32) if colour_gradients
            else cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32)) / 255.0
    g = cv2.GaussianBlur(grey, (5, 5), 1.0)
    gu, gv = C.strongest_channel(cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3, scale=1.0 / 8.0),
                                 cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3, scale=1.0 / 8.0))
    mag = gu * gu
    mag += gv * gv
    f = C._norm_factor(np.sqrt(mag), k_edge)
    ridges, lv = [], g
    for level in range(3):
        if level:
            lv = cv2.pyrDown(lv)
        uu, uv, vv = C.strongest_channel(*(cv2.Sobel(lv, cv2.CV_32F, dx, dy, ksize=3,
                                                     scale=0.25)
                                           for dx, dy in ((2, 0), (1, 1), (0, 2))))
        fr = C._norm_factor(np.sqrt(uu * uu + uv * uv + vv * vv), k_ridge)
        ridges.append(cv2.merge([0.5 * (uu - vv) * fr, uv * fr, 0.5 * (uu + vv) * fr,
                                 np.zeros_like(fr)]))
    return cv2.merge([gu * f, gv * f]), ridges


@pytest.mark.parametrize("colour_gradients", [False, True])
@pytest.mark.parametrize("region", [None, (40, 16, 300, 230), (128, 40, 197, 133)])
def test_fused_map_normalisation_equals_numpys(scene, colour_gradients, region):
    _, _, img, lut, _ = scene
    maps = C.cue_maps(img, lut, region=region, colour_gradients=colour_gradients)
    gradient, ridges = reference_maps(img, lut, region, colour_gradients)
    assert same(maps.gradient, gradient)
    for (h, w), r, want in zip(maps.level_shapes, maps.level_rows, ridges, strict=True):
        assert same(maps.ridge[r:r + h, :w], want)
        assert not maps.ridge[r + h].any() and not maps.ridge[r:r + h, w:].any()
    assert np.abs(gradient).max() > 0.5             # strong edges: the normalisation saturates


def test_compiled_sample_box_equals_numpys_reductions(scene):
    body, T, _, _, q = scene
    view = limb_view(body, body.forward(q), INTRINSICS, T)
    centre, axes, angle = view.ellipses
    centre = centre.copy()
    centre[0, 0, 0], centre[1, 1, 1] = np.inf, np.nan
    r = np.maximum.reduce(axes, axis=-1)
    for k in range(2):
        c = centre[..., k]
        pts = np.concatenate([view.sides_uv[..., k].ravel(), view.axis_uv[..., k].ravel(),
                              (c - r).ravel(), (c + r).ravel()])
        pts = pts[np.isfinite(pts)]
        lo, hi = sample_box(view, (centre, axes, angle))
        assert lo[k] == pts.min() and hi[k] == pts.max()
    assert np.isnan(view.sides_uv).any()            # invalid parts were left out
