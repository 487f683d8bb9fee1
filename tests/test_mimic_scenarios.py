"""Mimicry end to end with oracle perception, thresholds set from the measured values with a
2-3x margin (measured 2026-11-23, in brackets): oracle wave at 1.2 m RMSE <= 10 mm [4.5] and
lag <= 15 ms [7.7, about half the 16.7 ms frame period: the paper's hold interpolation];
extrapolation's lag |lag| <= 1 ms [0.34]; the head still within 0.01 mm and 0.0012 deg [0.0036
mm, 0.00043 deg since the servos feed the Coriolis and centrifugal forces forward, 2026-11-29;
0.30 mm, 0.029 deg before] (gaze: 0.004 mm, 0.0004 deg [0.0012, 0.00011; 0.039, 0.0042
before]); gaze
keeps the head within 10 % of the wide image's width of its centre [6 %, at the start]. The
paper's goals (RMSE <= 25 mm, lag <= 50 ms) are in the benchmark report
(``benchmarks/bench_control.py --scenarios``). Small images (the oracle does not look at them)
keep these runs fast.
"""

from __future__ import annotations

import pytest

from humimic.run import run_one
from humimic.scenario import load_scenario

FAST = ["cameras.resolution=[80, 60]", "output.plots=false", "output.rerun=\"off\""]


def _run(root, tmp_path, name, *overrides, duration=None):
    sc = load_scenario(root / "scenarios" / f"{name}.yaml", [*FAST, *overrides],
                       duration=duration)
    return run_one(sc, tmp_path / name, rerun="off", progress=False)


@pytest.fixture(scope="module")
def wave(root, tmp_path_factory):
    return _run(root, tmp_path_factory.mktemp("wave"), "mimic_wave", duration=4.0)


def test_oracle_wave_meets_the_accuracy_goals(wave):
    m = wave["mimicry"]
    palm = m["R_palm"]
    assert palm["status"] == "ok"
    assert palm["rmse_mm"] <= 10.0
    assert 0.0 <= palm["lag_ms"] <= 15.0
    assert palm["clamped_fraction"] == 0.0 and palm["lost_fraction"] == 0.0


def test_a_mapping_on_a_still_hand_is_named_in_the_warning(root, tmp_path, wave):
    """The person waves the left hand while the mapping copies the right: the robot has nothing
    to copy, and the run's warning line says so (the waving hand's RMS motion about its mean:
    measured 167 mm over 2.5 s; the still hand's 0.0 -- the avatar is scripted)."""
    from humimic.metrics.summary import verdict_warning

    assert 80.0 <= wave["mimicry"]["R_palm"]["mapped_motion_rms_mm"] <= 340.0
    assert "mimicry.R_palm" not in (verdict_warning(wave) or "")
    m = _run(root, tmp_path, "mimic_wave", "human.motion.hand=left", duration=2.0)
    assert m["mimicry"]["R_palm"]["mapped_motion_rms_mm"] < 1e-6  # measured 0.0
    assert "mimicry.R_palm: its human part right_hand hardly moved" in verdict_warning(m)


def test_both_interpolation_modes_are_scored_and_extrapolation_cancels_the_lag(wave):
    interp = wave["mimicry"]["R_palm"]["interpolation"]
    assert set(interp) == {"hold", "extrapolate"}
    assert interp["extrapolate"]["rmse_mm"] < interp["hold"]["rmse_mm"]
    assert abs(interp["extrapolate"]["lag_ms"]) <= 1.0 and interp["hold"]["lag_ms"] >= 4.0


def test_no_limit_no_nan_and_the_head_stays_still(wave):
    m = wave["mimicry"]
    assert m["joints"]["limit_violations"] == 0 and m["joints"]["finite"]
    assert m["head_still"]["max_displacement_mm"] <= 0.01
    assert m["head_still"]["max_rotation_deg"] <= 0.0012
    assert m["ik"]["failures"] == 0


def test_joint_limit_hits_name_the_joints(root, tmp_path):
    """An arm started 0.35 rad from its adduction stop (the old ready pose): the wave drives the
    shoulder abduction onto its band (ticks counted per joint; a tick where two joints touch
    counts once in the total)."""
    old_ready = "robot.pose={R_SFE: 0.3, R_SAA: 0.15, R_HR: 0.0, R_EB: 1.4}"
    palm = _run(root, tmp_path, "mimic_wave", old_ready, "mimic.fit.enabled=false",
                duration=3.0)["mimicry"]["R_palm"]
    by_joint = palm["joint_limit_hits_by_joint"]
    assert set(by_joint) <= {"R_SFE", "R_SAA", "R_HR", "R_EB", "R_WR", "R_WFE", "R_WAA",
                             "B_TR", "B_TAA", "B_TFE"}
    assert palm["joint_limit_hits"] > 0 and "R_SAA" in by_joint
    assert max(by_joint.values()) <= palm["joint_limit_hits"] <= sum(by_joint.values())


def test_error_budget_splits_the_error_where_it_arises(wave):
    """A noise-free oracle with no declared latency: what control receives is the truth at its
    photon time (the estimate term vanishes: the series are aligned), and the hold between
    frames -- the estimate's age, all of it a fresh hold: nothing is delayed or lost --
    makes most of the error."""
    palm = wave["mimicry"]["R_palm"]
    b, share = palm["error_budget_mm"], palm["error_budget_share"]
    assert b["estimate"] < 1e-9
    assert b["pipeline_delay"] == 0.0 and b["stale_hold"] == 0.0
    assert share["fresh_hold"] > 0.8  # measured 1.23 (the PD's lag cancels part: -0.15)
    assert palm["measurements_rmse_mm"] is None  # the oracle measures nothing
    assert palm["estimates_rmse_mm"] < 1e-9
    assert wave["latency_ms"]["end_to_end"] == 0.0  # nothing declared: no delay
    assert wave["lag_ms"]["end_to_end"] == palm["lag_ms"]


def test_latency_is_the_delay_from_photon_to_joint_command(root, tmp_path):
    """An oracle 30 ms late: each frame is first used by the servo tick at or after its ready
    time, so photon to joint command is 30 ms plus less than one servo period (2.4 ms)."""
    lat = _run(root, tmp_path, "mimic_wave", "mimic.oracle.latency=0.03",
               duration=1.0)["latency_ms"]
    assert lat["estimate"] == pytest.approx(30.0, abs=1e-6)
    assert 30.0 <= lat["end_to_end"] <= lat["end_to_end_max"] < 30.0 + 1e3 / 420.0


def test_a_target_lost_most_of_the_run_is_flagged_and_its_error_budgeted_as_stale(root,
                                                                                tmp_path):
    """The left eye covered from 0.5 s to 3.5 s of a 4 s oracle wave: no estimate for 3 s,
    the target lost (its estimate over 0.25 s old) on about 2.75 / 4 of the ticks. The site
    is flagged ``lost_often``, its verdict is bad, and the error budget puts the held
    estimate's error where it arises -- the stale hold, not a latency: the oracle declares
    none, so ``pipeline_delay`` is exactly zero (the fresh hold is the truth's motion in the
    0.25 s before the estimate counts as stale). Measured 2026-11-29: lost 0.69, RMSE 208 mm,
    stale_hold 229 mm (share 1.05), fresh_hold 46 mm (share -0.11)."""
    from humimic.report.verdicts import verdicts

    m = _run(root, tmp_path, "mimic_wave",
             "cameras.covered=[{camera: left, start: 0.5, end: 3.5}]", duration=4.0)
    palm = m["mimicry"]["R_palm"]
    assert 0.6 <= palm["lost_fraction"] <= 0.75
    assert palm["status"] == "lost_often" and "right_hand lost on" in palm["reason"]
    b, share = palm["error_budget_mm"], palm["error_budget_share"]
    assert b["pipeline_delay"] == 0.0
    assert share["stale_hold"] > 0.8 and b["stale_hold"] > 2.5 * b["fresh_hold"]
    items = {v.label: v for v in verdicts(m)}
    assert items["mimicry R_palm: RMSE / lag"].status == "bad"
    assert "lost on" in items["mimicry R_palm: RMSE / lag"].value


def test_gaze_keeps_the_sweeping_head_near_the_image_centre(root, tmp_path):
    m = _run(root, tmp_path, "mimic_gaze", duration=4.5)["mimicry"]
    gaze = m["gaze"]
    assert gaze["status"] == "ok"
    assert gaze["max_offset_frac"] <= 0.10
    assert gaze["within_10pct_fraction"] == 1.0
    # The eyes move, the head does not.
    assert m["head_still"]["max_displacement_mm"] <= 0.004
    assert m["head_still"]["max_rotation_deg"] <= 0.0004


def test_a_target_never_seen_leaves_the_robot_holding_its_pose(root, tmp_path):
    """2 m to the side at 1.2 m, the person is outside the 100-degree cameras' view."""
    m = _run(root, tmp_path, "mimic_wave", "human.lateral=2.0", duration=1.0)["mimicry"]
    palm = m["R_palm"]
    assert palm["status"] == "never_detected"
    assert "right_hand" in palm["reason"] and "image" in palm["reason"]
    assert palm["held_pose"] and palm["robot_max_displacement_mm"] < 1e-6  # measured 0.0


def test_a_start_after_the_run_reports_not_started(root, tmp_path):
    m = _run(root, tmp_path, "mimic_wave", "mimic.start=5.0", duration=0.5)["mimicry"]
    assert m["R_palm"]["status"] == "not_started"
    assert "mimic.start" in m["R_palm"]["reason"]
