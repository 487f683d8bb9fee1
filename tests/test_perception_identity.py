"""Blob identities (head / right hand / left hand share the skin colour) from image rules,
stereo consistency, metric size and continuity. Scenes are built from 3-D truth with a synthetic
stereo head; the expected names are the ones the truth gives."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from _synth_vision import stereo_head

from humimic.perception.blobs.identity import (
    Blob,
    assign,
    image_rule_cost,
    stayed_on_own_blob,
    stereo_evidence,
    turned_round,
)
from humimic.perception.blobs.sizes import HAND_RADIUS_M, HEAD_RADIUS_M
from humimic.perception.blobs.stereo import StereoRig

TARGETS = ["head", "right_hand", "left_hand"]
#: Person ~1.2 m in front (base x forward, y left, z up): their right hand is at +y.
TRUTH = {"head": ((1.25, 0.0, 1.55), 0.047), "right_hand": ((1.05, 0.30, 1.25), 0.028),
         "left_hand": ((1.15, -0.25, 1.0), 0.022)}
TURNED = {"head": TRUTH["head"], "right_hand": ((1.15, -0.25, 1.0), 0.028),
          "left_hand": ((1.05, 0.30, 1.25), 0.022)}
"""The same person with the back to the robot: the right hand at -y (the image's right)."""


def blobs_seen(cam, names, slots, radii=None, truth=TRUTH):
    """Blobs of ``names`` in ``cam`` placed in tracker ``slots``: the projected centre and an
    isotropic shape whose sigma radius is the part's metric radius at its depth."""
    out = []
    for name, slot in zip(names, slots, strict=True):
        p, r = truth[name]
        r = radii.get(name, r) if radii else r
        z = (np.linalg.inv(cam.T_base_cam) @ np.append(p, 1.0))[2]
        sigma_px = r * cam.intrinsics.fx / z
        out.append(Blob(slot, cam.project_base(np.array(p)), sigma_px**2 * np.eye(2)))
    return out


@pytest.fixture(scope="module")
def head():
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0, hfov_deg=90.0)
    return cam_l, cam_r, StereoRig(cam_l, cam_r)


def test_truth_is_named_from_any_slot_order(head):
    cam_l, cam_r, rig = head
    for perm_l, perm_r in itertools.product(itertools.permutations(range(3)), repeat=2):
        left = blobs_seen(cam_l, TARGETS, perm_l)
        right = blobs_seen(cam_r, TARGETS, perm_r)
        ev = stereo_evidence(rig, cam_l, cam_r, left, right)
        names_l, names_r, margins = assign(TARGETS, left, right, {}, {}, ev)
        assert names_l == dict(zip(perm_l, TARGETS, strict=True))
        assert names_r == dict(zip(perm_r, TARGETS, strict=True))
        assert min(margins.values()) >= 2.0


def test_stereo_evidence_pairs_only_corresponding_blobs(head):
    cam_l, cam_r, rig = head
    left, right = blobs_seen(cam_l, TARGETS, range(3)), blobs_seen(cam_r, TARGETS, range(3))
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    np.testing.assert_array_equal(ev.inconsistent, ~np.eye(3, dtype=bool))
    for i, name in enumerate(TARGETS):  # the metric size of each part is recovered
        assert ev.radius_m[i, i] == pytest.approx(TRUTH[name][1], rel=1e-9)  # measured 2e-17
    assert np.isnan(ev.radius_m[0, 1])


def test_a_lone_blob_is_named_by_its_size(head):
    cam_l, cam_r, rig = head
    for name in ("head", "right_hand"):
        left, right = blobs_seen(cam_l, [name], [2]), blobs_seen(cam_r, [name], [0])
        ev = stereo_evidence(rig, cam_l, cam_r, left, right)
        names_l, names_r, margins = assign(TARGETS, left, right, {}, {}, ev)
        if name == "head":  # a head-sized blob alone: surely the head
            assert names_l == {2: "head"} and names_r == {0: "head"}
            assert margins["head"] >= 1.0
        else:  # a hand-sized blob alone: not the head, but which hand cannot be told
            assert names_l[2] in ("right_hand", "left_hand") and names_r[0] == names_l[2]
            assert margins[names_l[2]] < 1.0


def test_one_eye_only_is_never_sure(head):
    cam_l, _, _ = head
    left = blobs_seen(cam_l, ["right_hand"], [1])
    _, names_r, margins = assign(TARGETS, left, [], {}, {}, None)
    assert names_r == {} and max(margins.values()) < 1.0


def test_continuity_survives_one_contrary_rule(head):
    """A hand that looks bigger than the head in both eyes (one rule) keeps its name; the
    evidence margin then says the names are doubtful."""
    cam_l, cam_r, rig = head
    radii = {"right_hand": 0.06}  # e.g. the hand brought close to the camera
    left = blobs_seen(cam_l, TARGETS, range(3), radii)
    right = blobs_seen(cam_r, TARGETS, range(3), radii)
    assert image_rule_cost({n: b for n, b in zip(TARGETS, left, strict=True)}) == 1.0
    prev = dict(enumerate(TARGETS))
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    names_l, names_r, margins = assign(TARGETS, left, right, prev, prev, ev)
    assert names_l == prev and names_r == prev
    assert margins["right_hand"] < 1.0  # too big for a hand: measured but flagged unsure


def test_image_rules_count_each_violation():
    def b(u, area):
        return Blob(0, np.array([u, 100.0]), area * np.eye(2))

    head, small, big = (lambda u: b(u, 100.0)), (lambda u: b(u, 10.0)), (lambda u: b(u, 400.0))
    assert image_rule_cost({"head": head(160), "right_hand": small(100),
                            "left_hand": small(220)}) == 0.0
    assert image_rule_cost({"head": head(160), "right_hand": small(220),
                            "left_hand": small(100)}) == 1.0 + 0.5 + 0.5  # crossed over
    assert image_rule_cost({"head": head(160), "right_hand": big(100)}) == 1.0  # bigger
    assert image_rule_cost({"right_hand": small(100)}) == 0.0


def test_size_classes_are_the_avatars_parts(root):
    """The size classes against the avatar model's own parts: the sigma radius of a uniform
    elliptic silhouette with semi-axes a, b is sqrt(a b) / 2. The head's class spans it seen
    from the front (y, z half-axes) to the side (x, z); a hand's end-on (x, y) to palm-on
    (x, z) (edge-on, y z, between)."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(root / "models" / "avatar.xml"))

    def silhouettes(geom: str) -> list[float]:
        a = m.geom(geom).size
        return [np.sqrt(a[i] * a[j]) / 2 for i, j in ((1, 2), (0, 2), (0, 1))]

    front, side, _ = silhouettes("head")
    assert HEAD_RADIUS_M == pytest.approx((front, side), abs=1e-4)
    for hand in ("r_hand", "l_hand"):
        _, palm, end = silhouettes(hand)
        assert HAND_RADIUS_M == pytest.approx((end, palm), abs=1e-4)


def test_size_likelihoods_against_numerical_integration():
    """The size classes' likelihoods (a uniform true radius plus Gaussian reading noise) and
    their lower-bound forms against scipy's quadrature of the convolution; the graded cost
    against its definition from scipy.stats values; the noise's growth with depth."""
    from scipy import integrate, stats

    from humimic.perception.blobs.sizes import (
        FULL_LOG_BF,
        head_log_bayes_factor,
        radius_sd_m,
        size_cost,
        size_log_likelihood,
    )

    assert radius_sd_m(2.2, 134.0) == pytest.approx(np.hypot(0.002, 0.5 * 2.2 / 134.0))
    def convolved(f, r, sd, lo, hi):  # the mean of f(r; x, sd) over x uniform on [lo, hi]
        return integrate.quad(lambda x: f(r, x, sd), lo, hi, epsabs=1e-12)[0] / (hi - lo)

    lo, hi = 0.0157, 0.0300
    for r, sd in ((0.025, 0.004), (0.041, 0.0085), (0.010, 0.002), (0.052, 0.005)):
        dens = convolved(stats.norm.pdf, r, sd, lo, hi)
        surv = convolved(stats.norm.sf, r, sd, lo, hi)
        assert size_log_likelihood(r, sd, lo, hi) == pytest.approx(np.log(dens), abs=1e-6)
        assert size_log_likelihood(r, sd, lo, hi, True) == pytest.approx(np.log(surv), abs=1e-6)

    def bf(r, sd):
        return np.log(convolved(stats.norm.pdf, r, sd, *HEAD_RADIUS_M)
                      / convolved(stats.norm.pdf, r, sd, *HAND_RADIUS_M))

    for r, sd in ((0.0412, 0.0085), (0.035, 0.0085), (0.038, 0.0049), (0.029, 0.0049)):
        llr = bf(r, sd)
        assert head_log_bayes_factor(r, sd) == pytest.approx(llr, abs=1e-6)
        assert size_cost(True, r, sd) == pytest.approx(min(1.0, max(0.0, -llr / np.log(3.0))),
                                                      abs=1e-3)
        assert size_cost(False, r, sd) == pytest.approx(min(1.0, max(0.0, llr / FULL_LOG_BF)),
                                                       abs=1e-3)
    assert size_cost(True, float("nan"), 0.005) == 0.0


def test_a_still_head_far_away_is_named_by_its_size():
    """A head 2.2 m away through the wide cameras (100 deg, 320 px: 3 px sigma radius) read
    41.2 mm in fig12_tbp_pointing, between the hard limits the size rule had (head >= 38 mm,
    hand <= 42 mm): no rule then said it was not a hand, and with a hand beside it the head's
    margin was 0, never published. Graded by the likelihood ratio with the reading's noise at
    that depth (8.5 mm; Bayes factor 4.4 for the head), it is the head, sure (margin 1); the
    hand beside it (30 mm) stays a hand, and a lone 30 mm blob is still not the head."""
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0, hfov_deg=100.0)
    rig = StereoRig(cam_l, cam_r)
    far = {"head": ((2.2, 0.0, 1.55), 0.0412), "right_hand": ((2.0, 0.30, 1.25), 0.030),
           "left_hand": ((2.1, -0.25, 1.0), 0.022)}
    names = ["head", "right_hand"]
    left = blobs_seen(cam_l, names, [0, 1], truth=far)
    right = blobs_seen(cam_r, names, [1, 0], truth=far)
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    assert ev.radius_m[0, 0] == pytest.approx(0.0412, rel=1e-6)
    assert ev.radius_sd_m[0, 0] == pytest.approx(0.0085, abs=3e-4)
    names_l, names_r, margins = assign(TARGETS, left, right, {}, {}, ev)
    assert names_l == {0: "head", 1: "right_hand"} and names_r == {1: "head", 0: "right_hand"}
    assert margins["head"] >= 1.0
    lone_l, lone_r = left[1:], right[1:]
    ev = stereo_evidence(rig, cam_l, cam_r, lone_l, lone_r)
    names_l, _, _ = assign(TARGETS, lone_l, lone_r, {}, {}, ev)
    assert names_l[1] in ("right_hand", "left_hand")


def test_a_head_cut_by_the_border_stays_the_head(head):
    """A head in a corner of the view is only partly seen: its blob is smaller than the hand's
    and its metric size under the head's minimum. Cut by the border, it keeps its name (and
    the hand its own); the same small blob inside the image is (rightly) not called the head."""
    cam_l, cam_r, rig = head
    small = {"head": 0.023, "right_hand": 0.030}
    names = ["head", "right_hand"]
    outcome = {}
    for clipped in (True, False):
        eyes = []
        for cam in (cam_l, cam_r):
            b = blobs_seen(cam, names, [0, 1], small)
            eyes.append([Blob(b[0].slot, b[0].centre, b[0].cov, clipped), b[1]])
        ev = stereo_evidence(rig, cam_l, cam_r, *eyes)
        names_l, names_r, _ = assign(names, *eyes, {}, {}, ev)
        outcome[clipped] = (names_l, names_r)
    assert outcome[True] == ({0: "head", 1: "right_hand"}, {0: "head", 1: "right_hand"})
    assert outcome[False] != outcome[True]


def test_clipped_by_border():
    from humimic.perception.blobs.identity import clipped_by_border

    cov = np.diag([25.0, 100.0])  # 2 sigma: 10 px wide, 20 px high
    assert not clipped_by_border([100.0, 100.0], cov, 320, 240)
    assert clipped_by_border([8.0, 100.0], cov, 320, 240)
    assert clipped_by_border([100.0, 225.0], cov, 320, 240)


def test_a_person_turned_round_keeps_the_locked_hand_names(head):
    """With the back to the robot the person's right hand is at -y, on the image's right: every
    side rule then names the hands the wrong way round. Names that were sure and could not have
    been swapped since (locked) are kept, and reported unsure rather than renamed; the head,
    which the rules still name right, stays sure."""
    cam_l, cam_r, rig = head
    left = blobs_seen(cam_l, TARGETS, range(3), truth=TURNED)
    right = blobs_seen(cam_r, TARGETS, range(3), truth=TURNED)
    # the rules' view: the mirrored hands break the order rule and both side rules per eye
    cost = image_rule_cost(dict(zip(TARGETS, left, strict=True)))
    assert cost == 1.0 + 0.5 + 0.5
    truth_names = dict(enumerate(TARGETS))
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    # continuity alone (what a tracked blob had before the lock): renamed, and vouched for
    names_l, names_r, margins = assign(TARGETS, left, right, truth_names, truth_names, ev)
    assert names_l[1] == "left_hand" and names_r[1] == "left_hand"
    assert margins["right_hand"] >= 1.0
    # locked: the true names, the hands not vouched for, the head still sure
    names_l, names_r, margins = assign(TARGETS, left, right, truth_names, truth_names, ev,
                                       locked_left=truth_names, locked_right=truth_names)
    assert names_l == truth_names and names_r == truth_names
    assert margins["right_hand"] < 0.0 and margins["left_hand"] < 0.0
    assert margins["head"] >= 1.0
    # a lock on one hand in one eye is enough to keep both hands' names in that eye
    names_l, _, _ = assign(TARGETS, left, right, truth_names, truth_names, ev,
                           locked_left={2: "left_hand"})
    assert names_l == truth_names


def test_locked_names_that_mirror_the_rules_show_the_person_turned(head):
    """The turned person's locked (true) names break every side rule in both eyes and the
    mirrored rules not at all: turned round. Facing away, fresh blobs (no history, no lock) are
    then named right and surely; the person facing the robot is not judged turned, nor is one
    whose right hand alone crossed over to the image's right."""
    cam_l, cam_r, rig = head
    truth_names = dict(enumerate(TARGETS))
    eyes = [blobs_seen(cam, TARGETS, range(3), truth=TURNED) for cam in (cam_l, cam_r)]
    assert turned_round(*eyes, truth_names, truth_names, away=False)
    assert not turned_round(*eyes, truth_names, truth_names, away=True)  # already judged so
    ev = stereo_evidence(rig, cam_l, cam_r, *eyes)
    names_l, names_r, margins = assign(TARGETS, *eyes, {}, {}, ev, away=True)
    assert names_l == truth_names and names_r == truth_names
    assert min(margins.values()) >= 1.0
    facing = [blobs_seen(cam, TARGETS, range(3)) for cam in (cam_l, cam_r)]
    assert not turned_round(*facing, truth_names, truth_names, away=False)
    crossed = dict(TRUTH, right_hand=((1.05, -0.45, 1.25), 0.028))  # right of the left hand
    eyes = [blobs_seen(cam, TARGETS, range(3), truth=crossed) for cam in (cam_l, cam_r)]
    assert image_rule_cost(dict(zip(TARGETS, eyes[0], strict=True))) == 1.5  # order + side
    assert not turned_round(*eyes, truth_names, truth_names, away=False)


def test_locks_that_cannot_hold_bind_nothing(head):
    """Two slots locked to one name (no assignment keeps both): the rules decide as without
    locks."""
    cam_l, cam_r, rig = head
    left, right = blobs_seen(cam_l, TARGETS, range(3)), blobs_seen(cam_r, TARGETS, range(3))
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    free = assign(TARGETS, left, right, {}, {}, ev)
    bad = {1: "left_hand", 2: "left_hand"}
    assert assign(TARGETS, left, right, {}, {}, ev, locked_left=bad) == free


def test_a_lock_that_can_hold_holds_beside_one_that_cannot(head):
    """A lock naming no target (or a name another lock takes too) binds nothing; the other
    locks of that eye still hold: the turned person's locked left hand keeps its name."""
    cam_l, cam_r, rig = head
    left = blobs_seen(cam_l, TARGETS, range(3), truth=TURNED)
    right = blobs_seen(cam_r, TARGETS, range(3), truth=TURNED)
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    truth_names = dict(enumerate(TARGETS))
    for bad in ({0: "nose"}, {0: "right_hand", 1: "right_hand"}):
        names_l, _, _ = assign(TARGETS, left, right, truth_names, truth_names, ev,
                               locked_left={2: "left_hand", **bad})
        assert names_l == truth_names


def test_names_the_locks_fix(head):
    """Locked names, the head, a locked blob's only stereo partner, and the last blob of a full
    eye are fixed; a name the rules alone chose is not."""
    from humimic.perception.blobs.identity import fixed_names

    cam_l, cam_r, rig = head
    left = blobs_seen(cam_l, TARGETS, range(3))
    right = blobs_seen(cam_r, TARGETS, range(3))
    ev = stereo_evidence(rig, cam_l, cam_r, left, right)
    assert (~ev.inconsistent).sum() == 3  # each blob's partner is unique
    names = dict(enumerate(TARGETS))
    full = fixed_names([{2: "left_hand"}, {}], (names, names), (left, right), ev, 3)
    assert full == [names, names]  # the right eye's left hand by stereo, right hands last
    two = fixed_names([{2: "left_hand"}, {}], ({0: "head", 2: "left_hand"}, names),
                      (left[::2], right), ev.__class__(ev.inconsistent[::2], ev.radius_m[::2]),
                      3)
    assert two == [{0: "head", 2: "left_hand"}, names]
    assert fixed_names([{}, {}], (names, names), (left, right), ev, 3) == [{0: "head"}] * 2


def test_core_releases_a_lock_when_em_could_have_swapped_the_blob():
    """PerceptionCore keeps a sure name locked while its blob is tracked without a break and its
    region of interest (em_blobs.rois_overlap) touches no other same-coloured blob's; a blob
    that came that close, was lost, or restarted (younger than when locked) loses its lock."""
    from humimic.perception.blobs.config import PerceptionConfig
    from humimic.perception.blobs.core import PerceptionCore
    from humimic.perception.cues.color_models import ColorLUT, fit_color_model

    rng = np.random.default_rng(0)
    lut = ColorLUT(fit_color_model(rng.integers(100, 200, (500, 3)).astype(np.uint8), "rgb", 1,
                                   rng))
    core = PerceptionCore(PerceptionConfig(targets=TARGETS), ("L", "R"), dict.fromkeys(TARGETS,
                          lut), rng)
    sd = 2.0  # px: each region spans +-(3 sd + 4 px) = +-10 px
    cov = sd**2 * np.eye(2)

    def tracked(hand_gap: float, with_right: bool = True):
        blobs = {0: Blob(0, np.array([160.0, 60.0]), 16 * cov),
                 2: Blob(2, np.array([200.0, 150.0]), cov)}
        if with_right:
            blobs[1] = Blob(1, np.array([200.0 - hand_gap, 150.0]), cov)
        return [blobs, dict(blobs)]

    def locked_after(trk, age_now=12):
        core.locked = [{k: (n, 10) for k, n in enumerate(TARGETS)} for _ in range(2)]
        for t in core.trackers:
            t.tracker._age[:] = age_now
        core._release_locks(0.0, trk, core._touching(trk))
        return [sorted(lk) for lk in core.locked]

    assert locked_after(tracked(25.0)) == [[0, 1, 2]] * 2  # apart: every name stays locked
    assert locked_after(tracked(15.0)) == [[0]] * 2  # the hands' regions overlap
    assert locked_after(tracked(25.0, with_right=False)) == [[0, 2]] * 2  # right hand lost
    assert locked_after(tracked(25.0), age_now=3) == [[]] * 2  # restarted since locked


def test_a_blob_stays_on_its_own_object_only_by_a_wide_margin():
    """stayed_on_own_blob: the blob's step (3-4-5 triangles, so the distances are exact) against
    a third of its new distance to the nearest other blob's last centre."""
    prev = np.array([100.0, 50.0])
    other = np.array([100.0, 74.0])  # 24 px below
    # 5 px step sideways: 5 from its own last centre, |(4, 21)| = 21.4 from the other's
    assert stayed_on_own_blob(prev, prev + [3.0, -4.0], [other])
    # 5.5 px towards the other: 18.5 / 3 = 6.17 from it, still its own; 6.5 px: 17.5 / 3 =
    # 5.83 < 6.5, no longer
    assert stayed_on_own_blob(prev, prev + [0.0, 5.5], [other])
    assert not stayed_on_own_blob(prev, prev + [0.0, 6.5], [other])
    # handed to the other object: on its place
    assert not stayed_on_own_blob(prev, other + [0.5, 0.0], [other])
    # merging blobs (centres 4 px apart, a 1.5 px step towards the other): not judged its own
    assert not stayed_on_own_blob(prev, prev + [0.0, 1.5], [prev + [0.0, 4.0]])
    # the nearest of several counts; no other blob: nothing to be confused with
    assert not stayed_on_own_blob(prev, prev + [3.0, 4.0], [other, prev + [12.0, 14.0]])
    assert stayed_on_own_blob(prev, prev + [30.0, 40.0], [])
