"""The end-of-run summary table shows every score section of shared/design.md's namespaces."""

from humimic.metrics.summary import summary_rows


def test_every_family_shows_its_scores():
    metrics = {
        "scenario": "s", "seed": 1,
        "stages": {"render": {"mean_ms": 1.0, "calls": 3}},
        "trackers": {"icu": {"lost_fraction": 0.05, "reacquire_s": [0.0, 0.1],
                             "recognition": {"tutor_accepted": 174}}},
        "slam": {"ate_rmse_m": 0.04}, "arm": {"wrist_rmse_m": 0.02},
        "commands": {"sent": 3}, "lag_ms": {"end_to_end": 21.5},
        "faults": {"dropped": 2},  # what was injected, not a score
    }
    rows = dict(summary_rows(metrics))
    assert rows["stages.render"] == "1.000 ms x 3"
    assert rows["trackers.icu.lost_fraction"] == "0.05"
    assert rows["trackers.icu.recognition.tutor_accepted"] == "174"
    assert rows["slam.ate_rmse_m"] == "0.04"
    assert rows["arm.wrist_rmse_m"] == "0.02"
    assert rows["commands.sent"] == "3"
    assert rows["lag_ms.end_to_end"] == "21.5"
    assert not any(k.startswith("trackers.icu.reacquire_s") for k in rows)  # lists stay out
    assert not any(k.startswith("faults") for k in rows)


def test_measurements_inconsistent_with_their_covariance_are_warned():
    """A target whose debiased raw NEES lies above the 95 % band on over 20 % of frames (a
    skin-like shirt: 53-57 %) is named; the default wave's 0-2 % is not, nor a covariance too
    large (NEES below the band: outside it, but not above)."""
    from humimic.metrics.summary import verdict_warning

    def m(above, frames=300, verdict="ok"):
        return {"tracking": {"right_hand": {
            "verdict": verdict, "measured_frames": frames, "detection_rate": 0.9,
            "cause": "occluded", "raw_nees_pos3_debiased_in_band": 0.3,
            "raw_nees_pos3_debiased_above_band": above, "filtered_nees_pos3_in_band": 0.23}}}

    assert verdict_warning(m(0.02)) is None
    assert verdict_warning(m(0.53)) == (
        "warning: right_hand's 3-D measurements scatter beyond the covariance perception "
        "reports (debiased NEES above the 95 % band on 53% of frames; filtered NEES in the "
        "band on 23%)")
    assert verdict_warning(m(0.53, frames=10)) is None  # too few frames to judge
    assert verdict_warning(m(None)) is None
    assert "scatter" not in verdict_warning(m(0.53, verdict="poor"))  # named as poor already


def test_a_lost_target_and_a_person_out_of_view_are_named_in_the_warning_line():
    from humimic.metrics.summary import verdict_warning

    site = {"status": "ok", "target": "right_hand", "lost_fraction": 0.0,
            "mapped_motion_rms_mm": 150.0}
    assert verdict_warning({"mimicry": {"R_palm": site}, "person_view": {"warning": None}}) \
        is None
    lost = site | {"status": "lost_often", "lost_fraction": 0.6,
                   "reason": "right_hand lost on 60% of the ticks"}
    view = "the scripted person passes through the robot"
    line = verdict_warning({"mimicry": {"R_palm": lost}, "person_view": {"warning": view}})
    assert line == (f"warning: {view}; mimicry.R_palm: right_hand lost on 60% of the ticks")
