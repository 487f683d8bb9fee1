"""Shape and motion cues (Menezes eqs. 2-5) against brute-force computations."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from humimic.perception.cues.edges import (
    canny,
    colour_canny,
    distance_transform,
    dt_distance,
    edge_maps,
    least_cost_along_normal,
    nearest_along_normal,
    normal_edge_distance,
    normal_offsets,
    shape_log_likelihood,
    strongest_channel_sobel,
    without_ipp,
)
from humimic.perception.cues.motion import (
    OpticalFlow,
    edge_code,
    motion_dt_distance,
    motion_edge_maps,
    motion_normal_distance,
    moving_edges,
)
from humimic.perception.cues.templates import hand, head_and_shoulders, resample_contour


def _random_edges(rng, shape=(120, 160), n_lines=6) -> np.ndarray:
    e = np.zeros(shape, np.uint8)
    for _ in range(n_lines):
        p0 = tuple(int(v) for v in rng.integers(0, shape[::-1]))
        p1 = tuple(int(v) for v in rng.integers(0, shape[::-1]))
        cv2.line(e, p0, p1, 255, 1)
    return e


def _brute_nearest(edges: np.ndarray, pts: np.ndarray) -> np.ndarray:
    yx = np.argwhere(edges > 0)
    d, _ = cKDTree(yx[:, ::-1].astype(float)).query(pts.reshape(-1, 2))
    return d.reshape(pts.shape[:-1])


def test_colour_canny_sees_an_equal_brightness_boundary_grey_canny_misses():
    """A skin-coloured disc on a grey wall of (nearly) its brightness: grey Canny finds nothing,
    the colour gradient finds the circle's rim (every edge pixel within 1.5 px of it); on a
    grey image both are OpenCV's Canny exactly."""
    img = np.full((80, 80, 3), 160, np.uint8)
    cv2.circle(img, (40, 40), 15, (230, 150, 110), -1)       # grey 169 against 160
    assert not canny(img).any()
    e = colour_canny(img)
    yy, xx = np.nonzero(e)
    r = np.hypot(xx - 40, yy - 40)
    assert len(r) > 60 and np.abs(r - 15).max() < 1.5, (len(r), np.abs(r - 15).max())
    grey = cv2.cvtColor(np.random.default_rng(0).integers(0, 255, (60, 70, 3), np.uint8),
                        cv2.COLOR_RGB2GRAY)
    g3 = np.repeat(grey[..., None], 3, axis=2)
    blurred = cv2.GaussianBlur(grey, (0, 0), 1.0)
    np.testing.assert_array_equal(colour_canny(g3),
                                  cv2.Canny(blurred, 50.0, 150.0, L2gradient=True))
    # the strongest channel's gradient, as an integer argmax over the squared magnitudes picks
    rgb = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 256, (70, 90, 3), np.uint8),
                           (0, 0), 1.5)
    b = cv2.GaussianBlur(rgb, (0, 0), 1.0)
    dx = cv2.Sobel(b, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    dy = cv2.Sobel(b, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    k = np.argmax(dx.astype(np.int64) ** 2 + dy.astype(np.int64) ** 2, axis=2)[..., None]
    gx = np.ascontiguousarray(np.take_along_axis(dx, k, 2)[..., 0])
    gy = np.ascontiguousarray(np.take_along_axis(dy, k, 2)[..., 0])
    np.testing.assert_array_equal(colour_canny(rgb),
                                  cv2.Canny(gx, gy, 50.0, 150.0, L2gradient=True))


def test_strongest_channel_sobel_is_opencvs_sobel_at_the_integer_argmax():
    """The compiled gradient equals ``cv2.Sobel`` (3 x 3, replicated border) of the channel
    with the largest squared magnitude (first on ties), on random images of any size."""
    rng = np.random.default_rng(2)
    for h, w in ((1, 1), (2, 7), (13, 1), (31, 44), (60, 59)):
        img = rng.integers(0, 256, (h, w, 3), np.uint8)
        img[: h // 2] = img[: h // 2, :, :1]                   # equal channels: ties
        dx = cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
        dy = cv2.Sobel(img, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
        dx, dy = dx.reshape(h, w, 3), dy.reshape(h, w, 3)
        k = np.argmax(dx.astype(np.int64) ** 2 + dy.astype(np.int64) ** 2, axis=2)[..., None]
        gx, gy = strongest_channel_sobel(img)
        np.testing.assert_array_equal(gx, np.take_along_axis(dx, k, 2)[..., 0])
        np.testing.assert_array_equal(gy, np.take_along_axis(dy, k, 2)[..., 0])


def test_distance_transform_is_the_brute_force_nearest_edge_distance():
    rng = np.random.default_rng(0)
    edges = _random_edges(rng)
    dt = distance_transform(edges, cap=1e9)
    pts = np.stack([rng.integers(0, 160, (20, 15)), rng.integers(0, 120, (20, 15))], -1)
    brute = _brute_nearest(edges, pts.astype(float))
    # float32 distances: measured 2.4e-7 px off (the bound was 1e-3)
    np.testing.assert_allclose(dt_distance(dt, pts, cap=1e9), brute.mean(axis=1), atol=1e-5)
    # between pixels the bilinear DT stays within half a diagonal of the true distance
    frac = rng.uniform([0, 0], [159, 119], (20, 15, 2))
    per_point = dt_distance(dt, frac[:, :, None, :], cap=1e9, reduce="sum")
    assert np.max(np.abs(per_point - _brute_nearest(edges, frac))) < 0.75
    # capped, and points off the image count the cap
    capped = distance_transform(edges, cap=5.0)
    assert capped.max() <= 5.0
    assert dt_distance(capped, np.array([[[-50.0, 10.0]]]), cap=5.0)[0] == 5.0
    assert np.all(distance_transform(np.zeros((10, 10), np.uint8), 7.0) == 7.0)


def test_exact_distance_transform_is_scipys_to_the_bit():
    """The exact transform is the float32 of the exact Euclidean distance (scipy's), bit for
    bit, on cue-box sized images (odd row lengths): IPP's path, which rounds by the output's
    address, differed by an ulp on ~10 % of the pixels; and OpenCV's IPP switch is restored
    after, also after an error."""
    rng = np.random.default_rng(7)
    use = cv2.ipp.useIPP()
    for shape, p in (((51, 73), 0.02), ((51, 51), 0.05), ((37, 90), 0.2), ((240, 320), 0.01)):
        edges = np.where(rng.random(shape) < p, 255, 0).astype(np.uint8)
        want = ndimage.distance_transform_edt(edges == 0).astype(np.float32)
        np.testing.assert_array_equal(distance_transform(edges, cap=1e9), want)
        assert cv2.ipp.useIPP() == use
    with pytest.raises(ZeroDivisionError), without_ipp():
        assert not cv2.ipp.useIPP()
        _ = 1 / 0
    assert cv2.ipp.useIPP() == use


def test_normal_search_matches_a_pixel_walk_and_bounds_the_dt_distance():
    rng = np.random.default_rng(1)
    edges = _random_edges(rng, n_lines=10)
    pts = rng.uniform([5, 5], [154, 114], (12, 9, 2)) + 0.123  # off the half-pixel ties
    ang = rng.uniform(0, 2 * np.pi, (12, 9))
    nrm = np.stack([np.cos(ang), np.sin(ang)], -1)
    search = 12
    got = nearest_along_normal(edges, pts, nrm, search)
    walk = np.full(got.shape, np.inf)
    for i, j in np.ndindex(got.shape):
        for t in sorted(range(-search, search + 1), key=abs):
            x, y = np.floor(pts[i, j] + t * nrm[i, j] + 0.5).astype(int)
            if 0 <= x < 160 and 0 <= y < 120 and edges[y, x]:
                walk[i, j] = abs(t)
                break
    np.testing.assert_array_equal(got, walk)
    # the nearest edge along a line is never nearer than the nearest edge at all
    found = np.isfinite(got)
    assert np.all(got[found] >= _brute_nearest(edges, pts)[found] - 0.71)
    D = normal_edge_distance(edges, pts, nrm, search)
    np.testing.assert_allclose(D, np.minimum(walk, search).mean(axis=1))


def test_eq2_and_eq3_agree_on_a_circle_and_peak_at_the_true_state():
    img = np.zeros((240, 320, 3), np.uint8)
    cv2.circle(img, (160, 120), 40, (255, 255, 255), -1)
    maps = edge_maps(img)
    circle = resample_contour(np.stack([np.cos(t := np.linspace(0, 2 * np.pi, 400)[:-1]),
                                        np.sin(t)], -1), 30, closed=True)
    states = np.array([[160.0, 120.0, r] for r in (30.0, 35.0, 40.0, 45.0)])
    p, n = circle.place(states)
    d_normal = normal_edge_distance(maps.edges, p, n, 15)
    d_dt = dt_distance(maps.dt, p)
    # measured 2026-11-29: [9.67, 4.67, 0, 4.87]; the DT within 0.13 px of it
    np.testing.assert_allclose(d_normal, [10, 5, 0, 5], atol=0.7)
    np.testing.assert_allclose(d_dt, d_normal, atol=0.35)
    ll = shape_log_likelihood(d_dt, sigma=1.5)
    assert np.argmax(ll) == 2 and ll[2] <= 0.0


def test_templates_place_scale_rotate_and_have_unit_normals():
    for t in (head_and_shoulders(15), hand(30)):
        seg = np.linalg.norm(np.diff(t.points, axis=0), axis=1)
        # roughly uniform along the contour: measured 0.070 and 0.003 (the bound was 0.35)
        assert seg.std() / seg.mean() < 0.2
        np.testing.assert_allclose(np.linalg.norm(t.normals, axis=1), 1.0, atol=1e-9)
        p, n = t.place(np.array([[100.0, 50.0, 20.0, np.pi / 2]]))
        R = np.array([[0.0, -1.0], [1.0, 0.0]])
        np.testing.assert_allclose(p[0], [100.0, 50.0] + 20.0 * t.points @ R.T, atol=1e-9)
        np.testing.assert_allclose(n[0], t.normals @ R.T, atol=1e-9)
        # many states at once (every other row of a wider array): each its own rotation
        rng = np.random.default_rng(2)
        x = np.column_stack([rng.uniform(0, 320, (14, 2)), rng.uniform(5, 60, 14),
                             rng.uniform(-4, 4, 14), np.zeros(14)])[::2]
        p, n = t.place(x)
        for i, (u, v, s, th, _) in enumerate(x):
            R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
            np.testing.assert_allclose(p[i], [u, v] + s * t.points @ R.T, atol=1e-9)
            np.testing.assert_allclose(n[i], t.normals @ R.T, atol=1e-12)
    h = hand(60)
    w, ht = np.ptp(h.points, axis=0)
    assert np.isclose(ht / w, 0.08 / 0.045, rtol=0.02)
    hs = head_and_shoulders(40)
    # crown above the centre: measured -0.640 with 40 points (the bound was 0.05)
    assert hs.points[:, 1].min() == pytest.approx(-0.65, abs=0.025)


def _moving_scene():
    a = np.full((120, 160), 60, np.uint8)
    cv2.rectangle(a, (10, 10), (50, 60), 200, -1)  # static square
    b = a.copy()
    cv2.circle(a, (100, 60), 15, 230, -1)
    cv2.circle(b, (104, 60), 15, 230, -1)  # the disc moved 4 px right
    return a, b


def test_moving_edges_follow_the_moving_object():
    a, b = _moving_scene()
    maps = edge_maps(b)
    flow = OpticalFlow()(a, b)
    mm = motion_edge_maps(maps, flow, min_flow_px=1.0)
    ys, xs = np.nonzero(mm.moving)
    assert len(xs) > 40
    on_disc = np.hypot(xs - 104, ys - 60) < 20
    assert on_disc.mean() > 0.9  # measured 1.0
    static_edges = maps.edges[5:66, 5:56] > 0
    assert (mm.moving[5:66, 5:56] > 0).sum() < 0.1 * static_edges.sum()
    none = motion_edge_maps(maps, None)
    assert not none.moving.any() and none.dt_moving.max() == pytest.approx(30.0)


def test_least_cost_along_normal_reads_the_probes_as_cv2_remap():
    """The compiled probe walk against OpenCV's nearest-neighbour remap of every probe,
    half-pixel ties (round half to even), probes off the image and NaN points included."""
    rng = np.random.default_rng(7)
    code = rng.integers(0, 3, (37, 53)).astype(np.uint8)
    pts = rng.uniform(-15, 65, (9, 30, 2))
    pts[::2] = np.round(pts[::2] * 2) / 2               # ties
    pts[0, 0] = np.nan
    ang = rng.uniform(0, 2 * np.pi, pts.shape[:-1])
    nrm = np.stack([np.cos(ang), np.sin(ang)], -1)
    nrm[1] = np.round(nrm[1] * 2) / 2                   # probes on ties too
    search = 6
    off = normal_offsets(search).astype(np.float32)[:, None, None]
    p, n = pts.astype(np.float32), nrm.astype(np.float32)
    u, v = p[..., 0] + off * n[..., 0], p[..., 1] + off * n[..., 1]   # (K, 9, 30)
    read = cv2.remap(code, u.reshape(len(off), -1), v.reshape(len(off), -1),
                     cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    # eq. 4's table (least cost 0: the walk stops at the first moving edge); one whose least
    # cost is positive (it stops later, at |o| + 0.4); one with a NaN (never stops early)
    tables = [np.full(256, np.inf), np.full(256, 2.5), np.full(256, np.inf)]
    tables[0][1], tables[0][2] = 0.7, 0.0
    tables[1][1], tables[1][2] = 0.4, 1.9
    tables[2][1], tables[2][2], tables[2][3] = 0.7, 0.0, np.nan
    for cost_of_value in tables:
        expect = np.fmin.reduce(np.abs(off[:, 0, 0]).astype(np.float64)[:, None]
                                + cost_of_value[read], axis=0)
        got = least_cost_along_normal(code, pts, nrm, search, cost_of_value)
        np.testing.assert_array_equal(got, expect.reshape(9, 30))
    got = least_cost_along_normal(code, pts, nrm, search, tables[0])
    assert np.isinf(got[0, 0]) and np.isfinite(got).mean() > 0.3   # measured 0.39


def test_eq5_and_eq4_against_direct_formulas():
    a, b = _moving_scene()
    mm = motion_edge_maps(edge_maps(b), OpticalFlow()(a, b), min_flow_px=1.0)
    rng = np.random.default_rng(4)
    pts = rng.integers([0, 0], [160, 120], (7, 11, 2)).astype(float)
    K = 0.5
    direct = np.minimum(mm.dt[pts[..., 1].astype(int), pts[..., 0].astype(int)],
                        K * mm.dt_moving[pts[..., 1].astype(int), pts[..., 0].astype(int)])
    # float32 maps: measured 9.5e-7 (2026-11-29; the bound was 1e-4)
    np.testing.assert_allclose(motion_dt_distance(mm, pts, K=K), direct.mean(axis=1), atol=1e-5)
    # eq. 4: a static edge costs rho more than a moving one at the same distance
    nrm = np.broadcast_to([1.0, 0.0], pts.shape)
    rho, search = 3.0, 10
    d_any = nearest_along_normal(mm.edges, pts + 0.1, nrm, search)
    d_mov = nearest_along_normal(mm.moving, pts + 0.1, nrm, search)
    expect = np.minimum(np.minimum(d_mov, d_any + rho), search + rho).mean(axis=1)
    np.testing.assert_allclose(motion_normal_distance(mm, pts + 0.1, nrm, rho, search), expect)
    # 2 px off a moving outline costs K times less than 2 px off a static one (eq. 5)
    circle = resample_contour(np.stack([np.cos(t := np.linspace(0, 2 * np.pi, 200)[:-1]),
                                        np.sin(t)], -1), 30, closed=True)
    inside_disc, _ = circle.place(np.array([[104.0, 60.0, 13.0]]))
    inside_square = np.array([[[12.0, y] for y in range(15, 56, 2)]])
    d_disc = motion_dt_distance(mm, inside_disc, K=K)[0]
    d_square = motion_dt_distance(mm, inside_square, K=K)[0]
    d_plain = motion_dt_distance(mm, inside_disc, K=1.0)[0]  # K = 1: plain eq. 3
    # measured 0.84, 3.0 and 1.68: every point of the disc's outline moves
    assert d_square > 1.4 and d_disc < 0.7 * d_square, (d_disc, d_square)
    assert abs(d_disc - K * d_plain) < 1e-6 and d_plain > 1.4  # measured 0 (was 0.15)


def test_rim_skin_distance_against_direct_pixel_sums_and_closed_forms():
    """A skin disc (posterior 1 inside, 0 outside): the hand template's outline on the disc's
    rim scores ~0, one outside the disc 1, the rim of a hole 2; and every value equals the
    mean of bilinear samples computed pixel by pixel (scipy's map_coordinates)."""
    from scipy.ndimage import map_coordinates

    from humimic.perception.cues.skin import rim_skin_distance

    yy, xx = np.mgrid[:120, :160]
    disc = ((xx - 80.0) ** 2 + (yy - 60.0) ** 2 <= 30.0 ** 2).astype(np.float32)
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = np.stack([np.cos(t), np.sin(t)], -1)
    contours = np.stack([[80, 60] + r * ring for r in (30.0, 20.0, 45.0)])
    D = rim_skin_distance(disc, contours, np.broadcast_to(ring, contours.shape), 3.0)
    assert D[0] < 0.05 and abs(D[1] - 1.0) < 1e-6 and abs(D[2] - 1.0) < 1e-6
    assert rim_skin_distance(1.0 - disc, contours[:1], ring[None], 3.0)[0] > 1.95
    for c, d in zip(contours, D, strict=True):
        inside = map_coordinates(disc, [(c - 3 * ring)[:, 1], (c - 3 * ring)[:, 0]], order=1)
        outside = map_coordinates(disc, [(c + 3 * ring)[:, 1], (c + 3 * ring)[:, 0]], order=1)
        assert abs(d - (1.0 - (inside.mean() - outside.mean()))) < 1e-5
    pts, inward = hand(30).place(np.array([[80.0, 60.0, 40.0, 0.0]]))
    assert np.all(np.sum((pts[0] - [80, 60]) * inward[0], axis=1) < 0)   # normals point in


def test_rim_skin_sides_and_the_relative_rim_test():
    """The two sides of a rim against map_coordinates' bilinear samples of a disc of skin
    posterior ``level`` (a dark hand's shaded rim reads ~0.5, the default skin's ~1) over a
    background of ``level / 4``: the relative test (inside >= 2 x outside) holds at every level
    the absolute one (1 - (inside - outside) <= 0.5) fails below 2/3 (closed form: inside -
    outside = 3/4 level); skin on neither side, or the same on both, fails it."""
    from scipy.ndimage import map_coordinates

    from humimic.perception.cues.skin import rim_separates, rim_skin_sides

    yy, xx = np.mgrid[:120, :160]
    disc = ((xx - 80.0) ** 2 + (yy - 60.0) ** 2 <= 30.0 ** 2).astype(np.float32)
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = np.stack([np.cos(t), np.sin(t)], -1)
    rim = np.array([80.0, 60.0]) + 30.0 * ring
    for level in (1.0, 0.7, 0.5, 0.3):
        skin = (level * (0.25 + 0.75 * disc)).astype(np.float32)
        inside, outside = rim_skin_sides(skin, rim[None], ring[None], 3.0)
        ref_in = map_coordinates(skin, [(rim - 3 * ring)[:, 1], (rim - 3 * ring)[:, 0]], order=1)
        ref_out = map_coordinates(skin, [(rim + 3 * ring)[:, 1], (rim + 3 * ring)[:, 0]],
                                  order=1)
        assert abs(inside[0] - ref_in.mean()) < 1e-5 and abs(outside[0] - ref_out.mean()) < 1e-5
        assert abs(inside[0] - level) < 1e-5 and abs(outside[0] - level / 4) < 1e-5
        assert rim_separates(inside, outside)[0]
        assert (1.0 - (inside[0] - outside[0]) <= 0.5) == (level >= 2 / 3)
    assert list(rim_separates([0.0, 0.6, 0.6, 0.6], [0.0, 0.6, 0.31, 0.3])) == [
        False, False, False, True]
    assert list(rim_separates([0.6, 0.6], [0.19, 0.21], odds=3.0)) == [True, False]


def test_moving_edges_is_the_edges_where_the_flow_is_long_enough():
    """Against the squared length compared in the flow's dtype (as numpy compares a float32
    array with a Python float), lengths just either side of the threshold included."""
    rng = np.random.default_rng(11)
    edges = np.where(rng.random((23, 31)) < 0.4, 255, 0).astype(np.uint8)
    for dtype in (np.float32, np.float64):
        for min_flow in (0.5, 0.7 ** 0.5, 1.3):
            flow = rng.normal(0, min_flow, (23, 31, 2)).astype(dtype)
            t = dtype(min_flow**2)
            flow[::3, :, 0], flow[::3, :, 1] = np.sqrt(t), 0      # on the threshold
            flow[1::5, :, 0] = np.nextafter(np.sqrt(t), dtype(0))
            flow[1::5, :, 1] = 0
            flow[2, 2] = np.nan
            long_enough = (flow[..., 0] * flow[..., 0] + flow[..., 1] * flow[..., 1]) >= t
            got = moving_edges(edges, flow, min_flow)
            np.testing.assert_array_equal(got, np.where((edges > 0) & long_enough, 255, 0))
            assert got.dtype == np.uint8 and 0.05 < (got > 0).mean() < 0.35


def test_rim_probes_are_numpys_float32_probes():
    """The compiled probes either side of a contour, against numpy's ``contour -+ offset *
    outward`` cast to float32 (the maps ``cv2.remap`` was given before)."""
    from humimic.perception.cues.skin import rim_probes

    rng = np.random.default_rng(12)
    contour = rng.uniform(-20, 180, (17, 30, 2))
    ang = rng.uniform(0, 2 * np.pi, (17, 30))
    outward = np.stack([np.cos(ang), np.sin(ang)], -1)
    for offset in (2.0, 0.3, 3.7):
        step = offset * outward
        expect = np.stack([contour - step, contour + step]).astype(np.float32)
        u, v = rim_probes(contour.reshape(-1, 2), outward.reshape(-1, 2), offset)
        np.testing.assert_array_equal(u, expect[..., 0].ravel())
        np.testing.assert_array_equal(v, expect[..., 1].ravel())


def test_edge_code_counts_edge_and_moving_edge():
    rng = np.random.default_rng(13)
    edges = rng.integers(0, 3, (19, 27)).astype(np.uint8) * 120        # 0, 120, 240
    moving = np.where(rng.random((19, 27)) < 0.5, edges, 0).astype(np.uint8)
    expect = (edges > 0).astype(np.uint8) + (moving > 0).astype(np.uint8)
    got = edge_code(edges, moving)
    assert got.dtype == np.uint8
    np.testing.assert_array_equal(got, expect)
    assert set(np.unique(got)) == {0, 1, 2}


def test_remap_uv_takes_more_rows_than_one_remap_call():
    """``cv2.remap`` refuses maps of 32767 rows or more (40 000 states x 30 points crashed eq. 3):
    laid out in rows of 1024, as one call per half (to float32 rounding: SIMD order)."""
    from humimic.perception.cues.edges import remap_uv

    rng = np.random.default_rng(0)
    img = rng.random((40, 50), dtype=np.float32)
    u, v = rng.uniform(-5, 55, (2, 40000, 30)).astype(np.float32)
    got = remap_uv(img, u, v, 3.0, cv2.INTER_LINEAR)
    want = np.concatenate([remap_uv(img, u[:20000], v[:20000], 3.0, cv2.INTER_LINEAR),
                           remap_uv(img, u[20000:], v[20000:], 3.0, cv2.INTER_LINEAR)])
    assert got.shape == (40000, 30)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)  # measured 1.2e-7 (values < 3)
