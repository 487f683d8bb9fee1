"""The 2-D hand tracker (Menezes sec. 5.1) on synthetic frames: likelihood peak, detection,
tracking, loss and re-acquisition; its scenario keys."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.cues.templates import hand
from humimic.perception.trackers.hand2d.config import Hand2DConfig
from humimic.perception.trackers.hand2d.detect import detect_hands
from humimic.perception.trackers.hand2d.likelihood import (
    Params,
    frame_cues,
    log_likelihood,
    roi_of,
    skin_fraction,
)
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker, skin_mask
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import validate_scenario

SKIN = (162, 125, 102)  # the avatar's skin as the foveal camera renders it
W, H = 320, 240


@pytest.fixture(scope="module")
def lut():
    return ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))


def _frame(rng, hands=((160.0, 120.0, 30.0, 0.0),), disk=None, plain=False) -> np.ndarray:
    """A checker background (clutter) with skin-coloured hand ellipses (u, v, width,
    theta) and optionally a skin disk (u, v, radius)."""
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.where(((xx // 12 + yy // 12) % 2)[..., None] == 0, 40, 190).astype(np.uint8)
    if plain:
        img[:] = 40
    img = np.repeat(img, 3, axis=2)
    for u, v, s, th in hands:
        cv2.ellipse(img, (round(u), round(v)), (round(s / 2), round(s * 0.89)),
                    np.degrees(th), 0, 360, SKIN, -1, cv2.LINE_AA)
    if disk is not None:
        cv2.circle(img, (round(disk[0]), round(disk[1])), round(disk[2]), SKIN, -1)
    noise = rng.normal(0, 2.0, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


def _params(**kw):
    base = dict(cues=("shape",), similarity="normal", sigma_s=36.0, rho=0.12, K=0.5,
                search_px=10, sigma_c=0.1)
    return Params(**{**base, **kw})


def _peak(cues, p, truth):
    du, ds, dth = np.meshgrid(np.arange(-6, 7, 2.0), np.arange(-6, 7, 3.0),
                              np.linspace(-0.3, 0.3, 5), indexing="ij")
    states = np.column_stack([truth[0] + du.ravel(), np.full(du.size, truth[1]),
                              truth[2] + ds.ravel(), truth[3] + dth.ravel()])
    ll = log_likelihood(cues, states, hand(30), p, None)
    return states[np.argmax(ll)] - truth


@pytest.mark.parametrize("similarity", ["normal", "dt"])
def test_likelihood_peaks_at_the_hand(similarity):
    truth = np.array([150.0, 110.0, 32.0, 0.3])
    img = _frame(np.random.default_rng(0), (truth,), plain=True)
    p = _params(similarity=similarity)
    cues = frame_cues(cv2.cvtColor(img, cv2.COLOR_RGB2GRAY), None, (0, 0), p, 0.5, None)
    err = _peak(cues, p, truth)
    # measured: on the truth's grid point (steps 2 px, 3 px, 0.15 rad; the bound was one step)
    np.testing.assert_array_equal(err, 0.0)


def _waving_frame(rng, h, arm_px: float = 30.0) -> np.ndarray:
    """The checker clutter with a hand (u, v, width, theta) as a waving one looks: its
    skin-coloured forearm continues it below the wrist (so the template's lowest points find no
    edge there) and a faint shading (+-10 %) moves with it (on a uniform ellipse the optical
    flow has only the rim to follow)."""
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.where(((xx // 12 + yy // 12) % 2)[..., None] == 0, 40, 190).astype(np.uint8)
    img = np.repeat(img, 3, axis=2)
    u, v, s, th = h
    down = np.array([-np.sin(th), np.cos(th)])
    wrist = np.array([u, v]) + 0.53 * s * down
    cv2.line(img, tuple(np.round(wrist).astype(int)),
             tuple(np.round(wrist + arm_px * down).astype(int)), SKIN, round(0.6 * s),
             cv2.LINE_AA)
    mask = np.zeros((H, W), np.uint8)
    cv2.ellipse(mask, (round(u), round(v)), (round(s / 2), round(s * 0.89)), np.degrees(th),
                0, 360, 255, -1, cv2.LINE_AA)
    shade = 1.0 + 0.1 * np.sin((xx - u) / 3.0) * np.sin((yy - v) / 3.0)
    a = (mask / 255.0)[..., None]
    img = (img * (1 - a) + np.asarray(SKIN) * shade[..., None] * a).astype(np.uint8)
    return np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("similarity", ["normal", "dt"])
def test_motion_singles_out_the_moving_hand_in_clutter(similarity):
    """Menezes eqs. 4 / 5 against 2 / 3: a hand waving in the checker clutter, its forearm
    hiding its wrist's edge. Over a +-60 x 36 px window the static edges alone (shape only)
    fit some checker squares better than the hand (the negative control); with moving edges
    preferred (eq. 4: static ones cost rho = 5 px; eq. 5: K = 0.5) the peak is on the hand."""
    from humimic.perception.cues.motion import OpticalFlow

    rng = np.random.default_rng(0)
    truth = np.array([100.0, 100.0, 32.0, 0.3])
    prev = _waving_frame(rng, truth - [3.0, 2.0, 0.0, 0.0])
    img = _waving_frame(rng, truth)
    g0, g1 = (cv2.cvtColor(x, cv2.COLOR_RGB2GRAY) for x in (prev, img))
    flow = OpticalFlow()(g0, g1)
    du, dv, ds, dth = np.meshgrid(np.arange(-60, 61, 2.0), np.arange(-36, 37, 3.0),
                                  np.arange(-3, 4, 3.0), np.linspace(-0.3, 0.3, 5),
                                  indexing="ij")
    states = truth + np.column_stack([du.ravel(), dv.ravel(), ds.ravel(), dth.ravel()])

    def peak(cues):
        p = _params(cues=cues, similarity=similarity, rho=5.0)
        ll = log_likelihood(frame_cues(g1, flow, (0, 0), p, 0.5, None), states, hand(30), p,
                            None)
        return states[np.argmax(ll)] - truth

    # measured (seed 0): the shape-only peak 39.7 px (eq. 2) / 34.8 px (eq. 3) from the hand,
    # on a clutter fit (seeds 0-7: 30-48 px); the bound is half a hand width
    assert np.hypot(*peak(("shape",))[:2]) > 15.0
    # measured: on the truth's grid point (steps 2 px, 3 px, 3 px, 0.15 rad), seeds 0-7; the
    # shape distance sum there 135 against 153 off the hand (eq. 5: 23.8 against 28.3)
    np.testing.assert_array_equal(peak(("shape", "motion")), 0.0)


def test_roi_and_skin_fraction(lut):
    pts = np.array([[[10.0, 20.0], [50.0, 200.0]]])
    assert roi_of(pts, 5, W, H) == (5, 15, 56, 206)
    assert roi_of(pts - 100, 5, W, H)[:2] == (0, 0)
    # against numpy's nanmin / nanmax over random clouds with NaN points, fractional margins
    rng = np.random.default_rng(3)
    for margin in (0.0, 4.5, 17.25):
        cloud = rng.uniform(-40, 360, (100, 30, 2))
        cloud[rng.random(cloud.shape) < 0.05] = np.nan
        lo = np.floor(np.nanmin(cloud.reshape(-1, 2), axis=0) - margin).astype(int)
        hi = np.ceil(np.nanmax(cloud.reshape(-1, 2), axis=0) + margin).astype(int) + 1
        expect = (max(0, min(lo[0], W - 2)), max(0, min(lo[1], H - 2)))
        expect += (min(W, max(hi[0], expect[0] + 2)), min(H, max(hi[1], expect[1] + 2)))
        assert roi_of(cloud, margin, W, H) == expect
    with np.errstate(invalid="ignore"):                     # NaN cast to int, as on main
        assert roi_of(np.full((2, 3, 2), np.nan), 5, W, H) == (0, 0, 2, 2)   # no point
    img = np.zeros((H, W, 3), np.uint8)
    img[:, :160] = SKIN  # left half skin
    left = skin_fraction(img, lut, np.array([100.0, 120.0, 30.0, 0.0]))
    edge = skin_fraction(img, lut, np.array([160.0, 120.0, 30.0, 0.0]))
    assert left > 0.95 and 0.4 < edge < 0.6  # a 6 x 6 lattice straddling the border


def test_skin_mask_drops_speckle_and_keeps_the_hand():
    """The detector's skin mask is the posterior's 3x3 box mean above 0.5 (against
    scipy's uniform filter): a surface whose colour only touches the skin model's (30 % of
    its pixels skin, scattered, as lab_clutter's dark posts under a dark skin: 18 %) makes
    hand-sized blobs in the raw mask and none in this one, while the hand stays whole."""
    from scipy.ndimage import uniform_filter

    from humimic.perception.cues.importance import skin_blobs

    rng = np.random.default_rng(0)
    post = np.zeros((H, W), np.float32)
    post[20:220, 200:215] = rng.random((200, 15)) < 0.3            # a speckled post
    cv2.ellipse(post, (100, 120), (15, 28), 0, 0, 360, 1.0, -1)     # the hand
    mask = skin_mask(post)
    np.testing.assert_array_equal(mask, uniform_filter(post, 3, mode="nearest") > 0.5)

    def blobs(m):
        return skin_blobs(m, subsample=2, min_area_px=64.0, aspect=(1.0, 3.0)).boxes

    assert len(blobs(post > 0.5)) >= 2                  # the post's speckle makes blobs
    np.testing.assert_array_equal(blobs(mask), [[86, 92, 30, 58]])   # the hand alone


def test_detection_takes_the_hand_not_the_disk(lut):
    rng = np.random.default_rng(1)
    img = _frame(rng, ((100.0, 120.0, 30.0, 0.0),), disk=(230.0, 110.0, 22.0))
    from humimic.perception.cues.edges import edge_maps

    maps = edge_maps(img)
    det = detect_hands(lut.posterior(img) > 0.5, maps.dt, np.zeros_like(maps.edges),
                       hand(30), 8.0, 3.0)
    assert det.best is not None and len(det.states) == 1
    assert np.hypot(*(det.best[:2] - [100, 120])) < 2.0 and abs(det.best[2] - 30) < 5


@pytest.mark.parametrize("filt", ["condensation", "icondensation"])
def test_tracks_loses_and_reacquires(lut, filt):
    rng = np.random.default_rng(2)
    cfg = Hand2DConfig(kind="hand2d", rho=5.0, filter=filt)
    tr = Hand2DTracker(cfg, lut, W, H, np.random.default_rng(3), faces=None)
    path = [(120.0 + 3.0 * k, 120.0 + 1.5 * k, 30.0, 0.01 * k) for k in range(20)]
    errs = []
    for h in path:
        s = tr.step(_frame(rng, (h,)))
        errs.append(np.hypot(s.mean[0] - h[0], s.mean[1] - h[1]))
    # measured median / max: CONDENSATION 1.6 / 3.9 px, ICONDENSATION 2.3 / 4.7 px
    assert s.state == "tracking" and np.median(errs) < 4.0 and max(errs) < 9.0
    states = [tr.step(_frame(rng, ())).state for _ in range(cfg.lost_frames + 1)]
    assert states[-1] == "lost" and np.all(np.isfinite(tr.pf.particles))
    s = tr.step(_frame(rng, ((200.0, 100.0, 30.0, 0.0),)))
    # measured 0.79 px (2026-11-29)
    assert s.state == "tracking" and np.hypot(s.mean[0] - 200, s.mean[1] - 100) < 2.0


def _scenario(**tracker):
    data = {"name": "t", "cameras": {"which": "foveal", "eyes": "left"},
            "trackers": {"hand": {"kind": "hand2d", **tracker}}}
    return validate_scenario(data, "t.yaml")


@pytest.mark.parametrize("key, value, fragment", [
    ("n_particles", 0, "trackers.hand.n_particles"),
    ("cues", ["motion"], "trackers.hand.cues"),
    ("bins", 10, "trackers.hand.bins"),
    ("sigma_s", -1.0, "trackers.hand.sigma_s"),
    ("colour", 1, "trackers.hand.colour"),
])
def test_bad_keys_name_the_key(key, value, fragment):
    with pytest.raises(ScenarioError, match=fragment.replace(".", r"\.")):
        _scenario(**{key: value})


def test_camera_not_rendered_names_the_key():
    from humimic.perception.trackers.hand2d.build import hand2d_stage

    sc = _scenario(camera="R_wide")

    class World:
        eye_cameras = ["L_foveal"]

    with pytest.raises(ScenarioError, match=r"trackers\.hand\.camera"):
        hand2d_stage("hand", sc.trackers["hand"], sc, World(), {}, None)


def test_fig5_scenario_tracks_the_hand_in_clutter(tmp_path):
    """Menezes Fig. 5, shortened to 1.5 s: the waving hand in front of the cluttered room
    (hand ~35 px wide). Measured with the skin cue: 1.5 s: 11 % lost (mostly the start),
    centre error median 0.81 px, RMSE 2.9 px; 4 s: 10 %, 0.91 / 2.4 px. Without it (the
    paper's shape + motion) in today's busier room: 16 %, 1.7 / 4.5 px; 4 s: 21 %. On
    2026-11-29 (1.5 s): none lost, acquired on the first frame, 0.76 / 0.89 px."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_fig5_hand.yaml", ["output.plots=false"],
                       duration=1.5)
    m = run_one(sc, tmp_path, rerun="save", progress=False)["trackers"]["hand"]
    assert m["frames"] == 90 and m["visible_frames"] == 90
    assert m["lost_fraction"] <= 0.05 and m["center_median_px"] < 2.0
    assert m["center_rmse_px"] < 2.5 and m["acquire_s"] < 0.05

    from rerun.chunk import RrdReader

    entities = {c.entity_path for c in RrdReader(tmp_path / "run.rrd").stream()}
    overlay = "/world/cameras/L_foveal/image/hand/"
    assert {overlay + "particles", overlay + "estimate", overlay + "detections",
            "/series/trackers/hand/state", "/series/trackers/hand/error_px"} <= entities


def test_hand_people_scenario_tracks_a_dark_skinned_tutor(tmp_path):
    """menezes_hand_people's first 2 s with a dark-skinned tutor (human.skin [0.40, 0.27,
    0.20]), seed 99: the learned skin model once also took lab_clutter's dark-brown posts
    (posterior 0.80; 0.19 after the ratio cut, but speckled), and the detector started on
    their speckle. Measured: 0 % lost, centre error median 0.92 px, RMSE 1.6 px, 0 identity
    switches, 0 wrong-person frames, 6 s of CPU (before: 61 %, 107 / 109 px, 1 switch, 73
    wrong-person frames)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_hand_people.yaml",
                       ["output.plots=false", "human.skin=[0.40,0.27,0.20]"],
                       duration=2.0, seed=99)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["hand"]
    assert m["visible_frames"] >= 100
    assert m["identity_switches"] == 0 and m["wrong_person_frames"] == 0
    assert m["lost_fraction"] <= 0.05 and m["center_median_px"] < 2.0
    assert m["center_rmse_px"] < 3.0  # measured 1.6, 1.19 px (2026-11-29)


def test_fig5_scenario_keeps_a_very_dark_hand(tmp_path):
    """menezes_fig5_hand (4 s) with a very dark hand (skin [0.25, 0.16, 0.11]) over
    lab_clutter's dark posts, seed 2: at 2.0 s the hand's colour edges are weak (mean edge
    distance 4.2-5.2 px) and the skin posterior just inside its shaded rim only 0.5-0.8. The
    absolute rim test (1 - (inside - outside) <= 0.5) declared it lost there while the estimate
    was 1.4-2.5 px from the hand: 10 frames lost after acquisition. The relative one (inside
    at least twice outside): none; centre error median 0.86 px, RMSE 1.35 px (2.00 px since
    detection takes a blob's axes from its moments, 29 Nov). (Acquisition
    takes 0.47 s: detection, unchanged.)"""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_fig5_hand.yaml",
                       ["output.plots=false", "human.skin=[0.25,0.16,0.11]"], seed=2)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["hand"]
    assert m["visible_frames"] == m["frames"] == 240 and m["acquire_s"] < 1.0
    lost_after = round(m["lost_fraction"] * 240) - round(m["acquire_s"] * 60)
    assert lost_after <= 3 and m["center_median_px"] < 2.0 and m["center_rmse_px"] < 3.0


def test_keeps_the_tutors_hand_past_another_persons_skin(lut):
    """Another person's skin in view (a face disk and a hand, both skin-coloured and still)
    while the tutor's hand sweeps between them, 1.6-1.8 hand widths from each at the closest:
    the tracker stays on the tutor's hand (no frame nearer a distractor than half a hand
    width). Measured (tracker seeds 5-8, the first frame waited for: two hands agree and
    nothing has moved yet): centre error medians 0.86-0.96 px, maxima 2.2-3.4 px, never on a
    distractor (on grey edges 0.79-1.03 / 2.8-3.5 px). Before the wait the first frame took
    the better template fit: the tutor's on grey edges by 0.11 px, the distractor's on
    colour edges (all 30 frames on it)."""
    rng = np.random.default_rng(4)
    cfg = Hand2DConfig(kind="hand2d", rho=5.0)
    tr = Hand2DTracker(cfg, lut, W, H, np.random.default_rng(5), faces=None)
    other_hand, face = (165.0, 65.0, 30.0, 0.3), (175.0, 182.0, 22.0)
    errs, wrong = [], 0
    for k in range(30):
        h = (90.0 + 5.0 * k, 120.0 + 6.0 * np.sin(k / 3.0), 30.0, 0.0)
        s = tr.step(_frame(rng, (h, other_hand), disk=face))
        if s.state == "tracking":
            errs.append(np.hypot(s.mean[0] - h[0], s.mean[1] - h[1]))
            wrong += min(np.hypot(*(s.mean[:2] - other_hand[:2])),
                         np.hypot(*(s.mean[:2] - face[:2]))) < 15.0
    assert len(errs) >= 27 and wrong == 0
    assert np.median(errs) < 2.5 and max(errs) < 9.0  # seed 5 on 2026-11-29: 0.86, 3.35 px


def test_hand_people_scenario_stays_on_the_tutor(tmp_path):
    """menezes_hand_people's first 2.3 s: the other person's face passes behind the waving
    hand (at ~2 s). Measured on these 2.3 s: 0 identity switches, 0 wrong-person frames, 9.4 %
    lost, centre error median 1.2 px (the paper's shape + motion without the skin cue: 22 %,
    2.9 px; whole 5 s: 13 % against 35 %)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_hand_people.yaml", ["output.plots=false"],
                       duration=2.3)
    run = run_one(sc, tmp_path, rerun="off", progress=False)
    m = run["trackers"]["hand"]
    assert m["others_near_frames"] >= 40  # the distraction was there (measured 97 frames)
    assert m["identity_switches"] == 0 and m["wrong_person_frames"] == 0
    # on 2026-11-29: none lost, median 0.84 px
    assert m["lost_fraction"] < 0.05 and m["center_median_px"] < 2.0



def test_hand_people_scenario_tracks_in_dim_light(tmp_path):
    """menezes_hand_people's first 1.5 s in dim light (``lighting.ambient: 0.1, diffuse:
    0.3``): the tutor's hand is as dark as the grey wall behind it, whose grey-level Canny
    edges left its rim (the template 21.8 px from the nearest grey edge at 0.67 s, 2.8 px on
    the colour gradient's). Measured with ``edges: colour`` (the default): 0 % lost, centre
    error median 0.90 px, RMSE 2.2 px; on grey edges (before): 47 % lost (median 1.3 px,
    RMSE 3.2 px while tracked)."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_hand_people.yaml",
                       ["output.plots=false", "lighting.ambient=0.1", "lighting.diffuse=0.3"],
                       duration=1.5)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["hand"]
    assert m["visible_frames"] == 90 and m["wrong_person_frames"] == 0
    assert m["lost_fraction"] <= 0.05 and m["center_median_px"] < 2.5  # measured 0, 0.90 px
    assert m["center_rmse_px"] < 5.0


def test_waits_for_motion_before_choosing_between_hands(lut):
    """Two still hand-shaped skin blobs on the first frame (no flow yet to say which waves):
    the detector waits; on the next frame the one that moved is taken, though the still one
    fits the template better (chamfer distance 0.93 against 0.97-1.03: the waving hand is
    turned by 0.3 rad)."""
    rng = np.random.default_rng(11)
    tr = Hand2DTracker(Hand2DConfig(kind="hand2d", rho=5.0), lut, W, H,
                       np.random.default_rng(12), faces=None)
    still, waving = (220.0, 80.0, 30.0, 0.0), (90.0, 130.0, 30.0, 0.3)
    assert tr.step(_frame(rng, (still, waving))).state == "init"
    s = tr.step(_frame(rng, (still, (waving[0] + 6.0, *waving[1:]))))
    # measured 0.78 px (2026-11-29)
    assert s.state == "tracking" and np.hypot(s.mean[0] - 96.0, s.mean[1] - 130.0) < 2.0
