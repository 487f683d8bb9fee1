"""Mimicry end to end with oracle perception: the issue's accuracy thresholds.

Thresholds are the issue's (measured values in brackets, for the margin): oracle wave at
1.2 m RMSE <= 10 mm [4.6] and lag <= 15 ms [7.7, about half the 16.7 ms frame period: the
paper's hold interpolation]; head still <= 1 cm and 1 deg [0.15 mm, 0.02 deg]; gaze keeps the
head within 10 % of the wide image's width of its centre [<= 6 %, at the start].
Small images (the oracle does not look at them) keep these runs fast.
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


def test_both_interpolation_modes_are_scored_and_extrapolation_cancels_the_lag(wave):
    interp = wave["mimicry"]["R_palm"]["interpolation"]
    assert set(interp) == {"hold", "extrapolate"}
    assert interp["extrapolate"]["rmse_mm"] < interp["hold"]["rmse_mm"]
    assert abs(interp["extrapolate"]["lag_ms"]) < 2.0 < interp["hold"]["lag_ms"]


def test_no_limit_no_nan_and_the_head_stays_still(wave):
    m = wave["mimicry"]
    assert m["joints"]["limit_violations"] == 0 and m["joints"]["finite"]
    assert m["head_still"]["max_displacement_mm"] <= 10.0
    assert m["head_still"]["max_rotation_deg"] <= 1.0
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


def test_error_budget_and_latencies_are_reported(wave):
    b = wave["mimicry"]["R_palm"]["error_budget_mm"]
    for key in ("perception", "filtering", "estimate", "latency", "interpolation", "workspace",
                "ik", "servo", "total"):
        assert b[key] is not None and b[key] >= 0.0, key
    assert b["total"] <= sum(b[k] for k in ("estimate", "latency", "interpolation",
                                            "workspace", "ik", "servo")) + 1e-9
    lat = wave["latency_ms"]
    assert lat["estimate"] == 0.0 and lat["end_to_end"] == wave["mimicry"]["R_palm"]["lag_ms"]


def test_gaze_keeps_the_sweeping_head_near_the_image_centre(root, tmp_path):
    m = _run(root, tmp_path, "mimic_gaze", duration=4.5)["mimicry"]
    gaze = m["gaze"]
    assert gaze["status"] == "ok"
    assert gaze["max_offset_frac"] <= 0.10
    assert gaze["within_10pct_fraction"] == 1.0
    # The eyes move, the head does not.
    assert m["head_still"]["max_displacement_mm"] <= 10.0
    assert m["head_still"]["max_rotation_deg"] <= 1.0


def test_a_target_never_seen_leaves_the_robot_holding_its_pose(root, tmp_path):
    """2 m to the side at 1.2 m, the person is outside the 100-degree cameras' view."""
    m = _run(root, tmp_path, "mimic_wave", "human.lateral=2.0", duration=1.0)["mimicry"]
    palm = m["R_palm"]
    assert palm["status"] == "never_detected"
    assert "right_hand" in palm["reason"] and "image" in palm["reason"]
    assert palm["held_pose"] and palm["robot_max_displacement_mm"] < 2.0


def test_a_start_after_the_run_reports_not_started(root, tmp_path):
    m = _run(root, tmp_path, "mimic_wave", "mimic.start=5.0", duration=0.5)["mimicry"]
    assert m["R_palm"]["status"] == "not_started"
    assert "mimic.start" in m["R_palm"]["reason"]
