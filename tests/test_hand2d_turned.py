"""The 2-D hand tracker (Menezes sec. 5.1) finds and follows a hand at any in-plane turn: a
hand held across the chest (palm edge-on, its long axis horizontal) was never a detection
candidate (the blob's box had to be upright, the template within 0.6 rad of upright)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.cues.edges import edge_maps
from humimic.perception.cues.templates import hand
from humimic.perception.trackers.hand2d.config import Hand2DConfig
from humimic.perception.trackers.hand2d.detect import blob_axes, detect_hands
from humimic.perception.trackers.hand2d.tracker import Hand2DTracker

SKIN = (162, 125, 102)  # the avatar's skin as the foveal camera renders it (test_hand2d's)
W, H = 320, 240
TURNS = (0.0, 0.4, 1.0, np.pi / 2, -1.2)


@pytest.fixture(scope="module")
def lut():
    return ColorLUT(load_color_model(DEFAULT_COLOR_MODEL))


def _frame(rng, hands) -> np.ndarray:
    """test_hand2d's checker clutter with skin-coloured hand ellipses (u, v, width, theta)."""
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.where(((xx // 12 + yy // 12) % 2)[..., None] == 0, 40, 190).astype(np.uint8)
    img = np.repeat(img, 3, axis=2)
    for u, v, s, th in hands:
        cv2.ellipse(img, (round(u), round(v)), (round(s / 2), round(s * 0.89)),
                    np.degrees(th), 0, 360, SKIN, -1, cv2.LINE_AA)
    return np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)


def _turn_error(a: float, b: float) -> float:
    """Angle between two hand turns, modulo the template's half turn (rad)."""
    return abs((a - b + np.pi / 2) % np.pi - np.pi / 2)


@pytest.mark.parametrize("theta", TURNS)
def test_blob_axes_recover_a_drawn_ellipse(theta):
    """Against the drawing's own parameters: cv2.ellipse filled with semi-axes 15 x 27 px
    (pixels -15..15 and -27..27 about the centre: 31 x 55 px across) turned by ``theta`` (the
    hand template's convention, as ``_frame`` draws hands). Measured: turns within 0.008
    rad, axes within 0.35 px."""
    img = np.zeros((H, W), np.uint8)
    cv2.ellipse(img, (160, 120), (15, 27), np.degrees(theta), 0, 360, 1, -1)
    th, width, length = blob_axes(img)
    assert _turn_error(th, theta) < 0.02
    assert abs(width - 31.0) < 0.7 and abs(length - 55.0) < 0.7


@pytest.mark.parametrize("theta", TURNS)
def test_detects_a_turned_hand(lut, theta):
    """A hand turned by ``theta`` on the checker clutter is the one detection, at its centre
    and turn. Measured: centre within 0.95 px, turn within 0.018 rad, width 3.3-3.9 px over
    the drawn 30 (the anti-aliased rim). Before: no candidate at 1.0, pi/2 and -1.2 rad (box
    not upright, template within 0.6 rad of upright); 0.4 rad found 0.1 rad off (the angle
    grid)."""
    img = _frame(np.random.default_rng(7), ((150.0, 110.0, 30.0, theta),))
    maps = edge_maps(img)
    det = detect_hands(lut.posterior(img) > 0.5, maps.dt, np.zeros_like(maps.edges),
                       hand(30), 8.0, 3.0)
    assert det.best is not None and len(det.states) == 1
    assert np.hypot(*(det.best[:2] - [150, 110])) < 2.0
    assert _turn_error(det.best[3], theta) < 0.05 and abs(det.best[2] - 30) < 7


def test_tracks_a_hand_held_across(lut):
    """A horizontal hand (turned by pi/2) moving and turning slowly over the clutter: found on
    the first frame and followed. Measured: centre error median 0.81 px, max 2.1 px, turn
    error max 0.056 rad (before: never found, state ``init`` throughout)."""
    rng = np.random.default_rng(2)
    tr = Hand2DTracker(Hand2DConfig(kind="hand2d", rho=5.0), lut, W, H,
                       np.random.default_rng(3), faces=None)
    errs, turns = [], []
    for k in range(20):
        h = (120.0 + 3.0 * k, 120.0 + 1.5 * k, 30.0, np.pi / 2 - 0.01 * k)
        s = tr.step(_frame(rng, (h,)))
        assert s.state == "tracking"
        errs.append(np.hypot(s.mean[0] - h[0], s.mean[1] - h[1]))
        turns.append(_turn_error(s.mean[3], h[3]))
    assert np.median(errs) < 2.0 and max(errs) < 5.0 and max(turns) < 0.15


def test_hand_people_scenario_with_a_hand_across_the_chest(tmp_path):
    """menezes_hand_people's first 1.5 s with the tutor's hand tracing a figure eight in front
    of the chest (palm edge-on, long axis horizontal; the other person's hanging hand at the
    image's left edge). Before: started on the other person's hand and stayed there, lost on
    100 % of the frames, 90 wrong-person frames, centre RMSE 200 px. Measured after: 1 %
    lost, centre error median 1.06 px, RMSE 2.2 px, no wrong-person frame."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_hand_people.yaml",
                       ["output.plots=false", "human.motion={kind: figure8}"], duration=1.5)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["hand"]
    assert m["visible_frames"] == 90
    assert m["identity_switches"] == 0 and m["wrong_person_frames"] == 0
    assert m["lost_fraction"] <= 0.05 and m["center_median_px"] < 2.5
    assert m["center_rmse_px"] < 6.0


def test_a_hand_merged_with_a_skin_coloured_bar_is_no_candidate(lut):
    """The hand (30 px, upright) across a skin-coloured bar 120 x 8 px (a look-alike surface,
    as lab_clutter's dark-brown bar is for a very dark hand): one blob 2.2 times longer than
    wide, filling 0.60 of its equal-moment ellipse -- no hand. Without the fill test it was
    taken as a hand 49 px wide turned by -1.9 rad (menezes_fig5_hand, skin [0.25, 0.16,
    0.11], seed 2: such a blob, fill 0.29, started the track 14-25 px off the hand for 0.35 s,
    RMSE 7.5 px over the run)."""
    img = _frame(np.random.default_rng(5), ((150.0, 110.0, 30.0, 0.0),))
    img[106:114, 90:210] = SKIN
    maps = edge_maps(img)
    det = detect_hands(lut.posterior(img) > 0.5, maps.dt, np.zeros_like(maps.edges),
                       hand(30), 8.0, 3.0)
    assert det.best is None
