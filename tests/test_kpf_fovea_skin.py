"""The foveal view's skin cue over the hand's sample points inside the narrow image
(``trackers.<kpf>.fovea.skin_in_view``, :class:`~humimic.perception.trackers.kpf.fovea.
FovealView`)."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, PALETTE, camera, painted_person, static_pose

from humimic import bodymodel as bm
from humimic.bodymodel.limb_view import limb_view
from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
from humimic.perception.cues.color_models import ColorLUT, load_color_model
from humimic.perception.trackers.kpf.config import KpfConfig
from humimic.perception.trackers.kpf.cues import CueMaps, skin_response
from humimic.perception.trackers.kpf.fovea import (
    FovealLikelihood,
    FovealView,
    disc_in_view,
    in_view_skin,
)
from humimic.perception.trackers.kpf.frame_cues import FrameCues
from humimic.perception.trackers.kpf.likelihood import Likelihood
from humimic.perception.trackers.kpf.tracker import kpf_body
from humimic.sensors.camera_model import Intrinsics

CFG = KpfConfig(sigma_from_spread=False, colour_gradients=True,
                sigma={"edge": 0.25, "ridge": 0.4, "colour": 0.15, "skin": 0.4})


def test_disc_in_view_is_the_skin_response_of_an_all_skin_image():
    """The share of the skin cue's points inside the image equals the skin cue (eq. 8, read
    through ``cv2.remap``, 0 off the image) on an image that is skin everywhere."""
    rng = np.random.default_rng(0)
    h, w = 60, 80
    ones = np.ones((h, w), np.float32)
    maps = CueMaps(np.zeros((h, w, 2), np.float32), np.zeros((h + 1, w, 4), np.float32),
                   np.array([[h, w]]), np.array([0]), np.zeros((h, w, 3), np.float32), ones)
    centre = rng.uniform([-20, -20], [w + 20, h + 20], (40, 3, 2))
    axes = np.sort(rng.uniform(2, 25, (40, 3, 2)), axis=-1)[..., ::-1]
    angle = rng.uniform(-np.pi, np.pi, (40, 3))
    got = disc_in_view(centre, axes, angle, w, h)
    want = skin_response(maps, centre, axes, angle)
    assert np.allclose(got, want, atol=1e-6)
    assert np.any((got > 0.0) & (got < 1.0)) and got.max() == 1.0


def test_in_view_skin_reads_the_points_off_the_image_in_the_wide_view():
    """17 points, ``m`` of them inside the narrow image, ``k`` of those skin, the hand's wide
    view skin fraction ``f_w``: the cue over all points reads ``k / 17`` (cost ``1 - k /
    17``); with the off-image points read in the wide view ``(k + (17 - m) f_w) / 17``."""
    k, m = np.array([0, 3, 5, 7, 0]), np.array([10, 5, 5, 17, 0])
    f_w = np.array([0.2, 1.0, 0.5, 0.0, 0.9])
    cost = in_view_skin(1.0 - k / 17, m / 17, 1.0 - f_w)
    assert np.allclose(cost, 1.0 - (k + (17 - m) * f_w) / 17)


def _hand_at_the_border():
    """The painted model seen by a narrow camera (f = 700 px) whose image's bottom edge runs
    through the raised right hand's centre; the poses: the truth and the right arm's
    perturbations."""
    body, T, q0 = kpf_body(), camera(), static_pose()
    narrow = Intrinsics(320, 240, 700.0, 700.0, 159.5, 119.5)
    fwd = body.forward(q0[None])
    view = limb_view(body, fwd, narrow, T)
    e = [body.part_names[i] for i in view.ellipsoid_idx].index("r_hand")
    u, v = view.ellipses[0][0, e]
    fi = Intrinsics(320, 240, 700.0, 700.0, 159.5 + (159.5 - u), 119.5 + (239.5 - v))
    labels = bm.label_mask(bm.project(body, fwd, fi, T))
    img = np.full((fi.height, fi.width, 3), 90, np.uint8)
    for p, name in enumerate(body.part_names):
        img[labels == p + 1] = PALETTE.get(name, (128, 128, 128))
    rng = np.random.default_rng(3)
    q = np.repeat(q0[None], 200, axis=0)
    q[1:, 6:10] += rng.normal(0.0, 0.08, (199, 4))
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    wide = FrameCues(painted_person(body, q0, T), lut, colour_gradients=True)
    cost_wide = Likelihood(body, INTRINSICS, CFG).evaluate(q, wide, T).cost["skin"]
    return body, fi, T, q, FrameCues(img, lut, colour_gradients=True), cost_wide, wide


@pytest.mark.parametrize("in_view", [False, True])
def test_a_hand_half_off_the_foveal_image_is_not_pulled_into_it(in_view):
    """Eq. 8 over all points scores the truth's hand, cut by the narrow image's edge (8 of
    its 17 points inside), worse than a pose that lifts it further into the image (measured
    2026-11-29: the best of the 105 such arm perturbations 0.23 nats above the truth on the
    hand's term); with the off-image points read in the wide view (``skin_in_view``) the
    truth beats them all (by 0.05) and the 40 that put the hand wholly off the narrow image
    (by 1.13)."""
    body, fi, T, q, maps, cost_wide, _ = _hand_at_the_border()
    view = FovealView(body, fi, CFG, skin_in_view=in_view)
    view.wide_skin(cost_wide)
    hand = body.part_names.index("r_hand")
    t = view.evaluate(q, maps, T, floors=True).terms[:, hand]
    lv = limb_view(body, body.forward(q), fi, T)
    e = [body.part_names[i] for i in lv.ellipsoid_idx].index("r_hand")
    c, a, ang = (x[:, e] for x in lv.ellipses)
    share = disc_in_view(c[:, None], a[:, None], ang[:, None], fi.width, fi.height)[:, 0]
    lifted, out = share > share[0], share == 0
    assert 0.3 < share[0] < 0.7 and lifted.sum() > 20 and out.sum() > 10
    margin = t[lifted].max() - t[0]
    if in_view:
        assert margin < -0.02
        assert t[out].max() - t[0] < -0.4
    else:
        assert margin > 0.1


def test_search_reads_the_wide_view_in_the_filter_not_in_the_decision():
    """``skin_in_view: search``: the two-view likelihood's foveal hand term is the wide-read
    one (:class:`FovealView` with ``skin_in_view``) in the filter's evaluations and eq. 8 over
    all points in the fixed-sigma ones (``floors``: the branch decision, the refinement);
    ``all``: the wide-read one in both."""
    body, fi, T, q, maps, cost_wide, wide = _hand_at_the_border()
    hand = body.part_names.index("r_hand")
    want = {}
    for read in (False, True):
        v = FovealView(body, fi, CFG, skin_in_view=read)
        v.wide_skin(cost_wide)
        want[read] = v.evaluate(q, maps, T, floors=True).terms[:, hand]
    assert not np.allclose(want[False], want[True])
    for mode, floors, read in (("search", False, True), ("search", True, False),
                               ("all", True, True), (None, False, False)):
        two = FovealLikelihood(body, INTRINSICS, CFG, fi, ("r_hand",), skin_in_view=mode)
        base = two.evaluate(q, wide, T, floors=floors).terms[:, hand]
        two.look(maps, T)
        got = two.evaluate(q, wide, T, floors=floors).terms[:, hand] - base
        assert np.allclose(got, want[read]), (mode, floors)
