"""Accuracy of the whole perception pipeline in the simulated world (Ude & Atkeson).

Each test runs a short scenario (rendered eyes -> EM blobs -> stereo -> random-jerk filter) and
scores it against ground truth that the pipeline never sees. Thresholds are the issue's; the
values measured when they were set are noted beside each (seed 1 unless said).
"""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest

from humimic.metrics.ude_tables import table2
from humimic.paths import SCENARIOS_DIR
from humimic.perception.blobs.stereo import StereoRig
from humimic.pipeline.build import build_stages
from humimic.pipeline.simulation import simulate
from humimic.pipeline.stage import Stage
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.viz.rerun_log import RerunLog
from humimic.world.names import ROBOT_JOINTS
from humimic.world.world import World

pytestmark = pytest.mark.slow


def run(name: str, overrides=(), duration: float | None = None, seed: int | None = None,
        extra=()) -> tuple[dict, dict, World]:
    """Run ``scenarios/<name>.yaml``; returns (metrics of the stages, stages by name, world)."""
    scenario = load_scenario(SCENARIOS_DIR / f"{name}.yaml", list(overrides), seed=seed,
                             duration=duration)
    rngs = Rngs(scenario.seed)
    world = World(scenario, rngs)
    rlog = RerunLog(world.scene, "off", None, "test")
    stages = build_stages(scenario, world, rngs, rlog) + [make(world) for make in extra]
    try:
        simulate(world, stages, rlog, progress=False)
        metrics: dict = {}
        for stage in stages:
            metrics.update(stage.metrics())
    finally:
        for stage in stages:
            stage.close()
        world.close()
    json.dumps(metrics, allow_nan=False)  # never a NaN in the outputs
    return metrics, {s.name: s for s in stages}, world


# ---- static hand (Table 3) -------------------------------------------------------------------
@pytest.fixture(scope="module")
def static_hand():
    """The still right hand ~1 m away, wide 640x480 (b = 0.3), 7 s: ~390 measured frames."""
    return run("ude_table3_static_hand", ["perception.detection.period=0.5"], duration=7.0)


def test_static_hand_wide_filter_smooths_depth(static_hand):
    t = static_hand[0]["tracking"]["right_hand"]
    raw, filt = t["raw_std_mm"], t["filtered_std_mm"]
    # base x is the depth. measured (seed 1, calibrated R): raw 0.67 mm, filtered 0.35 mm
    # (filtered/raw 0.53; the paper's Table 3: 0.48); on 2026-11-29 raw 0.44, filtered 0.25 mm
    assert filt[0] <= 0.7
    assert filt[0] <= 0.65 * raw[0]
    assert t["detection_rate_from_first"] == 1.0 and t["scored_estimates"] > 300
    for key in ("vel", "acc"):  # true value 0: the means are well inside their spread
        for mean, std in zip(t[f"{key}_bias_mm_s" if key == "vel" else "acc_bias_mm_s2"],
                             t[f"{key}_std_mm_s" if key == "vel" else "acc_std_mm_s2"],
                             strict=True):
            # measured <= 0.04 std before; on 2026-11-29 <= 0.0086 std (seeds 2-4: 0.0044,
            # 0.0096, 0.020: the bound 2x the worst seed; it was 0.1)
            assert abs(mean) <= 0.04 * std


def test_table2_propagated_matches_empirical_covariance(static_hand):
    """Ude's Table 2: the 2-D covariances of the correspondences, propagated through
    triangulation (the template-following model), against the empirical 3-D covariance of the
    same ~390 frames, as in the paper."""
    pa = static_hand[1]["tracking"].arrays()[0]
    t2 = table2(pa, "right_hand", skip_s=0.0, frame="base")
    ratio = np.diag(t2.propagated_following) / np.diag(t2.empirical)
    assert np.all(np.abs(ratio - 1.0) <= 0.4), ratio  # measured [1.17, 1.00, 0.81]
    # the paper's own model (independent left and right points) overstates depth here
    assert t2.propagated_independent[0, 0] / t2.empirical[0, 0] > 60.0  # measured 159


# ---- foveal -----------------------------------------------------------------------------------
def test_static_hand_foveal_depth_sigma():
    m = run("ude_static_hand_foveal", duration=3.0)[0]["tracking"]["right_hand"]
    assert m["scored_estimates"] > 100
    assert m["filtered_std_mm"][0] <= 0.8  # measured 0.34 mm (raw 0.57 mm)


# ---- wave -------------------------------------------------------------------------------------
def test_wave_detection_rate_and_filtered_rmse():
    """The wave by a person the shipped skin model misses (issue 9's hard case: very dark skin
    and a beige, skin-like shirt); the colour model is learned for them at start-up."""
    m = run("ude_wave_tracking", ["perception.detection.period=0.5",
                                  "human.skin=[0.30, 0.20, 0.15]",
                                  "human.shirt=[0.82, 0.70, 0.56]"], duration=4.5)[0]
    hand, head = m["tracking"]["right_hand"], m["tracking"]["head"]
    # the very dark skin's model takes few of the scene's pixels (measured 0.045 look-alike
    # pixels per skin pixel; 0.011 on 2026-11-29): no colour warning
    assert m["perception"]["skin_look_alike"] <= 0.04 and "colour_warning" not in m["perception"]
    # over the frames the hand is visible, after detection's phase one (the first detection
    # and the blob's settling take ~10 frames): measured 0.958; from the first on: 1.0
    assert hand["visible_fraction"] == 1.0 and hand["detection_rate"] >= 0.93
    assert hand["detection_rate_from_first"] >= 0.98
    assert hand["false_detection_rate"] <= 0.02  # the shirt is not the hand: measured 0.0
    assert hand["filtered_rmse_mm"] <= 15.0  # measured 6.5 mm (raw 7.9 mm)
    # a consistent filter: ~95 % of frames inside the band (measured 0.92)
    assert hand["filtered_nees_pos3_in_band"] >= 0.7 and not hand["biased"]
    # the head's stereo surface lies before its centre: flagged (raw RMSE 11.2 mm)
    assert head["detection_rate"] >= 0.93  # measured 0.971
    assert head["biased"] and head["raw_rmse_mm"] <= 20.0
    # the hand hanging still against the shirt is 8 px across: found by the colour-fitted
    # hypotheses at its own size (measured 0.946; never, while fits were at least 3 px sigma)
    left = m["tracking"]["left_hand"]
    assert left["detection_rate"] >= 0.85 and left["false_detection_rate"] <= 0.02, left


def test_wave_at_two_metres():
    """The default person 2.0 m away: the waving hand is ~9 px across (sigma ~2.2 px, under
    the random hypotheses' 3 px floor); the colour-fitted hypotheses find it right after phase
    one. The people sweep (6 s, seed 1): 0.970 of its visible frames, filtered 18.1 mm."""
    hand = run("ude_wave_tracking", ["perception.detection.period=0.5", "human.distance=2.0"],
               duration=3.0)[0]["tracking"]["right_hand"]
    assert hand["visible_fraction"] == 1.0 and hand["median_size_px"] < 10.0
    assert hand["detection_rate"] >= 0.85, hand  # measured 0.933 over 3 s (was 0.68)
    assert hand["false_detection_rate"] <= 0.03  # measured 0.010
    assert hand["filtered_rmse_mm"] <= 40.0  # the goal at 2.0 m; measured 16.6 mm


# ---- hidden for ~1 s --------------------------------------------------------------------------
class Visibility(Stage):
    """Test-only: pixels of the right hand's geom in each eye image (segmentation render)."""

    name = "visibility"

    def __init__(self, world):
        self.world, self.rows = world, []
        self.geom = world.scene.model.geom("human/r_hand").id

    def attach(self, bus, timer):
        bus.subscribe("frames", self._on_frames)

    def _on_frames(self, topic, msg):
        counts = []
        for cam in self.world.eye_cameras:
            seg = self.world.eye_rig.render_ideal(cam, segmentation=True)
            counts.append(int(((seg[..., 0] == self.geom)
                               & (seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM))).sum()))
        self.rows.append((msg.t, min(counts)))


def test_hidden_target_is_reacquired_within_half_a_second():
    metrics, stages, _ = run("ude_hidden_target", duration=4.5, extra=[Visibility])
    vis = np.array(stages["visibility"].rows)
    pa = stages["tracking"].arrays()[0]
    ok = pa.ok[:, pa.index("right_hand")]
    visible = vis[:, 1] >= 20  # px of hand in both eyes (a blob's worth)
    hidden = np.flatnonzero(~visible)
    assert len(hidden) and vis[hidden[-1], 0] - vis[hidden[0], 0] >= 0.9  # hidden ~1 s
    t_back = vis[hidden[-1] + 1, 0]  # visible again
    assert not ok[pa.t >= vis[hidden[0], 0]][: len(hidden)].all()  # it really was lost
    t_re = pa.t[(pa.t >= t_back) & ok][0]
    assert t_re - t_back <= 0.45  # measured 0.13-0.22 s (seeds 1-4)
    assert metrics["tracking"]["right_hand"]["reacquisitions"] >= 1


# ---- head and eye motion ----------------------------------------------------------------------
class MoveHead(Stage):
    """Test-only: turns the head and pans both eyes independently (sinusoids) at servo rate."""

    name = "move_head"

    def __init__(self, world):
        s = world.scene
        self.data = s.data
        self.act = {j: s.robot_actuators[ROBOT_JOINTS.index(j)] for j in
                    ("B_HR", "B_HN", "L_EP", "R_EP")}
        self.q0 = {j: float(s.data.ctrl[a]) for j, a in self.act.items()}

    def servo(self, t, bus):
        for j, amp, hz in (("B_HR", 0.15, 0.5), ("B_HN", 0.08, 0.35), ("L_EP", 0.08, 0.8),
                           ("R_EP", 0.06, 0.6)):
            self.data.ctrl[self.act[j]] = self.q0[j] + amp * math.sin(2 * math.pi * hz * t)


def test_head_and_eye_motion_is_compensated():
    sets = ["perception.detection.period=0.5", "cameras.resolution=[320, 240]"]
    still = run("ude_table3_static_hand", sets, duration=4.0)[0]["tracking"]["right_hand"]
    m, stages, _ = run("ude_table3_static_hand", sets, duration=4.0, extra=[MoveHead])
    moving = m["tracking"]["right_hand"]
    pa = stages["tracking"].arrays()[0]
    i = pa.index("right_hand")
    f = np.flatnonzero(pa.ok[:, i])
    eye_motion = np.linalg.norm(pa.T_base_cam[f, 0, :3, 2] - pa.T_base_cam[f[0], 0, :3, 2], axis=1)
    assert eye_motion.max() > 0.1  # the left eye's axis really turned (> 6 deg)
    assert moving["detection_rate_from_first"] >= 0.98
    # measured (seed 1): still 8.5 mm, moving 14.8 mm (filtered 3-D RMSE; the blobs move in
    # the images, the EM centre lags a little)
    assert still["filtered_rmse_mm"] <= 17.0 and moving["filtered_rmse_mm"] <= 30.0
    # the same correspondences triangulated with the eyes' pose at the first frame
    truth = stages["tracking"].truth(pa.t[f], "right_hand")[0]
    stale = StereoRig(pa.camera(f[0], 0), pa.camera(f[0], 1))
    p_stale, _ = stale.triangulate(pa.uv_match[f, i, 0], pa.uv_match[f, i, 1])
    stale_rmse = 1e3 * np.sqrt(np.mean(np.sum((p_stale - truth) ** 2, axis=1)))
    assert stale_rmse > 300.0 * moving["raw_rmse_mm"]  # measured 13.4 m vs 14.7 mm: 915x


# ---- a real person turning around (CMU clip) --------------------------------------------------
@pytest.mark.parametrize("seed", [1, 3])
def test_turning_person_hands_hidden_and_said_so(seed):
    """CMU subject 01 turns its back to the robot 1.6 m away (ude_cmu_turn): the visibility
    ground truth shows the hands hidden by the body after the turn, detection is scored over
    the frames a hand could be seen, and a poor hand says why. Seed 3: the hands' regions
    touched as the turn began (the left hand's lock held through it, see below)."""
    m, stages, world = run("ude_cmu_turn", seed=seed)
    tr = m["tracking"]
    vis = world.visibility.arrays()
    before, behind = vis.t <= 1.6, (vis.t >= 2.6) & (vis.t <= 3.0)
    for hand in ("right_hand", "left_hand"):
        j = vis.target(hand)
        assert vis.visible[before, :, j].all()  # facing the robot: both eyes see both hands
        # back to the robot: in view, hidden by the body (unoccluded 0 in every sample)
        assert vis.in_view[behind, :, j].all() and not vis.unoccluded[behind, :, j].any()
        s = tr[hand]
        assert 0.6 <= s["visible_fraction"] <= 0.9, s  # measured 0.714 (right), 0.829 (left)
        assert s["detection_rate"] > s["detection_rate_all"]  # hidden frames not held against
        assert s["verdict"] == "ok" or s["cause"], s  # a poor hand names its likely cause
    # after the turn the hands swap sides in the image and the side rules, which assume a
    # person facing the robot, name them the wrong way round. The left hand's blob, tracked
    # alone through the turn, keeps its sure name (perception.lock_names); that name breaking
    # every side rule, and the mirrored rules none, shows the person turned round and the
    # rules are mirrored (perception.track_facing), so the hands found afresh with the back
    # to the robot are named right too. Measured: no false report (main: right hand 31 %,
    # left 12 % of the reports false; the lock alone: 6 % / 12 %). Seed 3: the hands' regions
    # touched just before the right hand went behind the body; the left hand's lock, held
    # aside while they touched, came back (its blob stayed on its own object), so the turn
    # was seen: no false report (the lock dropped at the touch: right 37 %, left 35 % false)
    assert m["perception"]["facing_turns"] == 1
    for hand in ("right_hand", "left_hand"):
        assert tr[hand]["false_detection_rate"] <= 0.03, tr[hand]
    # coasted frames after the turn: measured right / left hand 61 / 80 mm (seed 1), 50 / 90
    # mm (seed 3; with the lock dropped at the touch 438 / 331 mm, the other hand's blob)
    assert tr["right_hand"]["predicted_rmse_mm"] <= 150.0, tr["right_hand"]
    assert tr["left_hand"]["predicted_rmse_mm"] <= 240.0, tr["left_hand"]
    # the hands are still measured on < 50 % of their visible frames (0.475 / 0.424, as on
    # main; seed 3 0.492 / 0.451): seen edge-on after the turn, their blobs (sd ~1 x 2.5 px)
    # fill too little of the stereo template (few_target_pixels)
    assert tr["right_hand"]["detection_rate"] >= 0.45
    assert any(tr[h]["verdict"] == "poor" for h in ("right_hand", "left_hand"))
    head = tr["head"]
    assert head["visible_fraction"] == 1.0 and head["detection_rate"] >= 0.7  # measured 0.828


# ---- a dark skin among lab_clutter's posts ---------------------------------------------------
def test_dark_skin_hand_found_among_clutter_posts():
    """lab_clutter's dark-brown posts are the colour of a dark skin's shade: the learned table
    is cut where the room's pixels outnumber the skin's (auto_colors.BACKGROUND_ODDS); without
    the cut the posts took the blobs and the right hand was measured on 2.5 % of the visible
    frames (with the likelihood-ratio cut, ``background_ratio`` 1.0: 7 %)."""
    m = run("ude_fig1_axes", ["room=lab_clutter", "human.skin=[0.40,0.27,0.20]"],
            duration=3.0, seed=77)[0]
    hand = m["tracking"]["right_hand"]
    # measured 0.917 (phase one ends at 1 s: found at 1.17 s, never lost); the same person in
    # the plain lab: 0.92-0.97
    assert hand["detection_rate"] >= 0.8 and hand["detection_rate_from_first"] >= 0.95, hand
    assert hand["false_detection_rate"] <= 0.02  # measured 0 (without the cut: 71 % false)
    assert hand["raw_rmse_mm"] <= 40.0  # measured 18 mm
    assert m["perception"]["skin_look_alike"] <= 0.1  # measured 0.03, 0.035 (uncut 2.0)


def test_a_darker_hand_going_behind_the_body_is_not_measured():
    """ude_cmu_turn seed 1 with a darker skin: as the right hand goes behind the body, every
    frame the visible-mass check finds hidden stays out of its reference, and the turning hand
    is judged against its frame-to-frame mass noise. Before, the second of the three hidden
    frames (184-193 mm too near) was measured between two refusals and the filter coasted on
    its velocity: predicted RMSE 283 mm, now 44 (the default person's: 62)."""
    m, _, _ = run("ude_cmu_turn", ["human.skin=[0.45,0.30,0.22]"], seed=1)
    s = m["tracking"]["right_hand"]
    assert s["stereo_failures"].get("shrinking_blob", 0) == 3, s["stereo_failures"]
    assert s["predicted_rmse_mm"] <= 120.0, s
