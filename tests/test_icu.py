"""The ICU tracker (Menezes sec. 5.2) on synthetic frames -- a person drawn as a skin head
with a real face crop (Haar-detectable) over a blue torso -- and its scenario keys."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from humimic.estimation.particles import Gaussian
from humimic.perception.cues.edges import edge_maps
from humimic.perception.cues.histograms import quantize
from humimic.perception.cues.templates import head_and_shoulders
from humimic.perception.faces.detect import FaceDetector
from humimic.perception.trackers.icu.config import IcuConfig
from humimic.perception.trackers.icu.likelihood import log_likelihood, references
from humimic.perception.trackers.icu.tracker import IcuTracker
from humimic.scenario.errors import ScenarioError
from humimic.scenario.load import validate_scenario
from humimic.world.faces import FACES_DIR

W, H = 320, 240
SKIN = np.array([162, 125, 102], float)
FACE = cv2.imread(str(FACES_DIR / "ben.png"), cv2.IMREAD_GRAYSCALE)


def person(rng, at=None) -> np.ndarray:
    """A frame with a person whose head (width s) is centred at ``at = (u, v, s)``; None: an
    empty room."""
    img = np.full((H, W, 3), (110, 120, 100), np.uint8)
    cv2.rectangle(img, (0, 200), (W, H), (60, 60, 70), -1)
    if at is not None:
        u, v, s = at
        cv2.rectangle(img, (round(u - 0.8 * s), round(v + 1.3 * s)),
                      (round(u + 0.8 * s), round(v + 2.6 * s)), (40, 60, 200), -1)
        cv2.ellipse(img, (round(u), round(v)), (round(s / 2), round(0.65 * s)), 0, 0, 360,
                    SKIN.tolist(), -1)
        n = round(0.9 * s)
        face = cv2.resize(FACE, (n, n), interpolation=cv2.INTER_CUBIC)[..., None] / 160.0
        x0, y0 = round(u - n / 2), round(v - n / 2)
        img[y0:y0 + n, x0:x0 + n] = np.clip(face * SKIN, 0, 255).astype(np.uint8)
    return np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)


def test_likelihood_peaks_at_the_person():
    truth = np.array([160.0, 80.0, 44.0])
    img = person(np.random.default_rng(0), truth)
    q = quantize(img, 32)
    refs = references(q, truth)
    du, dv, ds = np.meshgrid(np.arange(-8, 9, 2.0), np.arange(-8, 9, 2.0),
                             np.arange(-6, 7, 3.0), indexing="ij")
    states = truth + np.column_stack([du.ravel(), dv.ravel(), ds.ravel()])
    ll = log_likelihood(edge_maps(img).dt, q, states, head_and_shoulders(15), refs, 1.5, 0.03)
    err = states[np.argmax(ll)] - truth
    assert np.all(np.abs(err) <= [2.0, 2.0, 3.0]), err


def test_state_machine_tracks_loses_and_reinitialises():
    rng = np.random.default_rng(1)
    cfg = IcuConfig(kind="icu")
    tr = IcuTracker(cfg, W, H, np.random.default_rng(2), FaceDetector())
    assert tr.step(person(rng)).state == "init"  # nobody there
    errs = []
    for k in range(12):
        truth = np.array([120.0 + 2.0 * k, 80.0 + 0.5 * k, 44.0])
        s = tr.step(person(rng, truth))
        errs.append(np.hypot(*(s.mean[:2] - truth[:2])))
    assert s.state == "tracking" and np.median(errs) < 8.0 and max(errs) < 14.0  # 4.5, 7.2
    states = [tr.step(person(rng)).state for _ in range(cfg.lost_frames)]
    assert states[-1] == "lost" and np.all(np.isfinite(tr.pf.particles))
    s = tr.step(person(rng, (230.0, 90.0, 44.0)))
    assert s.state == "tracking" and np.hypot(s.mean[0] - 230, s.mean[1] - 90) < 5.0


def _scenario(**tracker):
    data = {"name": "t", "cameras": {"which": "foveal", "eyes": "left"},
            "trackers": {"icu": {"kind": "icu", **tracker}}}
    return validate_scenario(data, "t.yaml")


@pytest.mark.parametrize("key, value", [("n_particles", 0), ("bins", 3), ("sigma_c", 0.0),
                                        ("kappa", [0.1]), ("detect_every", 0)])
def test_bad_keys_name_the_key(key, value):
    with pytest.raises(ScenarioError, match=rf"trackers\.icu\.{key}"):
        _scenario(**{key: value})


def test_unknown_identity_and_missing_camera_name_the_key():
    from humimic.perception.trackers.icu.build import icu_stage

    class World:
        eye_cameras = ["L_foveal"]

    for tracker, key in (({"identity": "zed"}, "identity"), ({"camera": "R_wide"}, "camera")):
        sc = _scenario(**tracker)
        with pytest.raises(ScenarioError, match=rf"trackers\.icu\.{key}"):
            icu_stage("icu", sc.trackers["icu"], sc, World(), {}, None)


def test_fig9_scenario_acquires_the_tutor(tmp_path):
    """The Fig. 9 scenario's first second: the tutor is found at once and followed. Measured
    (whole 5 s run): 1.6 % lost, centre error median 4.7 px (head ~47 px), back in view to
    tracked in 0.05 s."""
    from humimic.paths import SCENARIOS_DIR
    from humimic.run import run_one
    from humimic.scenario import load_scenario

    sc = load_scenario(SCENARIOS_DIR / "menezes_fig9_leave_return.yaml",
                       ["output.plots=false"], duration=1.0)
    m = run_one(sc, tmp_path, rerun="off", progress=False)["trackers"]["icu"]
    assert m["visible_frames"] == 60 and m["acquire_s"] <= 0.05
    # this first second, 2026-11-29: none lost, median 2.6 px
    assert m["lost_fraction"] <= 0.05 and m["center_median_px"] < 6.0


def test_recognition_counts_name_whose_face_it_was():
    from humimic.metrics.tracks2d import ImageTruth
    from humimic.perception.trackers.icu.stage import recognition_counts

    def truth(u):
        return ImageTruth(np.array([[u, 100.0]]), np.array([40.0]), np.ones(1, bool),
                          np.ones(1))

    boxes = np.array([[80.0, 80.0, 40.0, 40.0], [180.0, 80.0, 40.0, 40.0],
                      [280.0, 80.0, 40.0, 40.0]])  # centres 100, 200, 300
    faces = [(0, boxes, np.array([0.9, 0.7, 0.8])), (0, boxes[:2], np.array([0.2, 0.1]))]
    out = recognition_counts(faces, truth(100.0), [truth(205.0)], 0.5)
    assert out == {"tutor_accepted": 1, "tutor_rejected": 1, "other_accepted": 1,
                   "other_rejected": 1, "false_detection": 1}



def mannequin(img: np.ndarray, at) -> np.ndarray:
    """``img`` with a faceless head and torso (a skin ellipse over a blue box, as
    :func:`person` draws them) at ``at = (u, v, s)``: clutter that fits the cues, no face."""
    u, v, s = at
    cv2.rectangle(img, (round(u - 0.8 * s), round(v + 1.3 * s)),
                  (round(u + 0.8 * s), round(v + 2.6 * s)), (40, 60, 200), -1)
    cv2.ellipse(img, (round(u), round(v)), (round(s / 2), round(0.65 * s)), 0, 0, 360,
                SKIN.tolist(), -1)
    return img


@pytest.mark.parametrize("redetect_after", [6, 0])
def test_a_drifted_cloud_finds_the_face_again(redetect_after):
    """A cloud drifted off the tutor onto clutter that fits its cues (as onto lab_clutter's
    shelves beside a nearing head) and whose loss test does not fire: the window's search
    misses the face's place and size; after ``redetect_after`` misses the whole-frame search
    finds it and restarts the filter there (0: never -- the cloud stays on the
    clutter, the regression's behaviour)."""
    rng = np.random.default_rng(3)
    cfg = IcuConfig(kind="icu", lost_colour=1.0, redetect_after=redetect_after)
    tr = IcuTracker(cfg, W, H, np.random.default_rng(4), FaceDetector())
    truth, clutter = np.array([220.0, 90.0, 50.0]), np.array([80.0, 70.0, 40.0])
    assert tr.step(person(rng, truth)).state == "tracking"
    tr.pf.initialize(tr.rng, Gaussian(clutter, np.eye(3)))
    steps = [tr.step(mannequin(person(rng, truth), clutter)) for _ in range(20)]
    assert tr.restarts == (1 if redetect_after else 0)
    found = [len(s.faces) > 0 for s in steps]
    err = np.hypot(*(steps[-1].mean[:2] - truth[:2]))
    if redetect_after:  # measured: found from the 7th frame on, final error 3.0 px
        assert not any(found[:redetect_after]) and all(found[redetect_after:])
        assert err < 9.0 and abs(steps[-1].mean[2] - truth[2]) < 8.0
    else:  # measured: never found, the estimate 121 px off
        assert not any(found) and err > 60.0


def test_a_cloud_beside_the_detected_face_counts_as_a_miss():
    """The tutor's face found in the window but half a face width from the estimate (Fig. 9
    in lab_clutter: the cloud sat 24 px beside a 55 px face box) counts toward
    ``redetect_after``; on the face it does not."""
    rng = np.random.default_rng(5)
    tr = IcuTracker(IcuConfig(kind="icu", lost_colour=1.0), W, H, np.random.default_rng(6),
                    FaceDetector())
    truth = np.array([160.0, 110.0, 50.0])
    assert tr.step(person(rng, truth)).state == "tracking"
    for offset, missed in ((0.0, 0), (24.0, 1)):
        tr.missed = 0
        tr.pf.initialize(tr.rng, Gaussian(truth + [offset, 0.0, 0.0], 0.01 * np.eye(3)))
        s = tr.step(person(rng, truth))
        assert len(s.faces) == 1 and tr.missed == missed, (offset, s.faces)
