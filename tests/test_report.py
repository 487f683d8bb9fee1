"""The one-page run report: NEES maths against independent computations, the page for a
finished run, and exit 2 for a directory that is not a run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.report.__main__ import main as report_main
from humimic.report.page import window_mean
from humimic.report.verdicts import verdicts
from humimic.run import run_one
from humimic.scenario import load_scenario


def test_window_mean_matches_a_loop_and_skips_nan():
    x = np.array([1.0, np.nan, 3.0, 5.0, np.nan, 7.0, 2.0, np.nan, np.nan, np.nan])
    n = 3
    expected = []
    for k in range(len(x)):
        w = x[max(0, k - n + 1):k + 1]
        w = w[np.isfinite(w)]
        expected.append(w.mean() if len(w) else np.nan)
    np.testing.assert_allclose(window_mean(x, n), expected, equal_nan=True)


def test_verdicts_flag_problems():
    good = {"sim_time_s": 4.0, "realtime_factor": 2.0, "interrupted": False,
            "mujoco_warnings": {},
            "tracking": {"right_hand": {"detection_rate": 1.0, "time_to_first_detection_s": 0.1,
                                        "filtered_rmse_mm": 7.0, "raw_rmse_mm": 9.0}}}
    assert all(v.status in ("ok", "info") for v in verdicts(good))
    bad = json.loads(json.dumps(good))
    bad["tracking"]["right_hand"].update(detection_rate=0.0, time_to_first_detection_s=None,
                                         filtered_rmse_mm=None, raw_rmse_mm=None)
    bad["mujoco_warnings"] = {"mjWARN_BADQACC": 3}
    statuses = {v.label: v.status for v in verdicts(bad)}
    assert statuses["MuJoCo warnings"] == "bad"
    assert statuses["right_hand: detection rate"] == "bad"


def test_verdicts_state_their_thresholds_and_flag_a_biased_target():
    """The head read through stereo: 21 mm closer than its centre, the filter no better than
    the raw measurements and over-confident -- none of it may look green."""
    head = {"detection_rate": 1.0, "time_to_first_detection_s": 0.1, "raw_rmse_mm": 23.1,
            "filtered_rmse_mm": 23.3, "raw_bias_mm": [-22.1, 0.8, 3.6], "raw_bias_share": 0.95,
            "biased": True, "filtered_nees_pos3_in_band": 0.3,
            "raw_nees_pos3_debiased_in_band": 0.9}
    items = {v.label: v for v in verdicts({"tracking": {"head": head}})}
    assert items["head: 3-D RMSE"].status == "warn"
    assert "does not improve" in items["head: 3-D RMSE"].value
    assert items["head: biased"].status == "warn" and "22" in items["head: biased"].value
    assert items["head: filter consistency"].status == "bad"
    assert "30 %" in items["head: filter consistency"].value
    for v in items.values():
        if v.label.startswith("head"):
            assert v.threshold, v.label  # every verdict says which rule made it


@pytest.mark.slow
def test_report_of_a_finished_tracked_run(tmp_path, capsys):
    scenario = load_scenario(SCENARIOS_DIR / "mimic_tracked_wave.yaml", duration=1.6)
    run_one(scenario, tmp_path, rerun="off", progress=False)  # writes the report itself
    for name, size in (("report.png", 50_000), ("report.html", 3_000)):
        assert (tmp_path / name).stat().st_size > size
        (tmp_path / name).unlink()
    assert report_main([str(tmp_path)]) == 0
    page = (tmp_path / "report.html").read_text()
    assert "right_hand: detection rate" in page and "χ² band" in page and "NEES = " in page
    assert (tmp_path / "report.png").stat().st_size > 50_000


def test_report_refuses_a_directory_that_is_not_a_run(tmp_path, capsys):
    assert report_main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not a humimic run directory" in err and len(err.splitlines()) == 1
    (tmp_path / "metrics.json").write_text("{not json")
    assert report_main([str(tmp_path)]) == 2
    assert "unreadable metrics.json" in capsys.readouterr().err


def test_trackers_get_a_verdict_line_with_their_own_errors():
    m = {"sim_time_s": 5.0, "trackers": {
        "icu": {"frames": 300, "visible_frames": 188, "center_rmse_px": 4.04,
                "lost_fraction": 0.07, "identity_switches": 0},
        "hand": {"frames": 300, "center_rmse_px": 9.0, "lost_fraction": 0.2,
                 "identity_switches": 2},
        "kpf": {"frames": 40, "wrist_error_mm": 63.2, "lost_fraction": 0.1}}}
    rows = {v.label: v for v in verdicts(m)}
    assert rows["tracker icu"].value == "4.0 px centre RMSE; lost on 7% of 188 visible frames"
    assert rows["tracker icu"].status == "info"
    assert rows["tracker hand"].status == "warn" and "2 identity switches" in rows[
        "tracker hand"].value
    assert rows["tracker kpf"].value == "63.2 mm mean wrist error; lost fraction 10%"


def test_the_nees_line_shows_only_beside_a_nees_verdict():
    from humimic.report.page import _nees_shown
    from humimic.report.verdicts import Verdict

    assert not _nees_shown([Verdict("tracker icu", "4.0 px centre RMSE", "info")])
    assert _nees_shown([Verdict("head: filter consistency", "80 % of frames inside the 95 % "
                                "χ² band of position NEES (3 dof)", "ok")])


def test_track2d_plot_is_written(tmp_path):
    from humimic.viz.plots import plot_track2d

    t = np.arange(50) / 30
    err = np.where(np.arange(50) < 30, 3.0, np.nan)
    path = plot_track2d(tmp_path / "tracker_x.png", t, err, np.arange(50) < 30,
                        (np.arange(50) >= 30).astype(float) * 2, ("init", "tracking", "lost"),
                        "x")
    assert path.is_file() and path.stat().st_size > 10_000


def test_a_site_whose_target_was_lost_most_of_the_run_is_not_ok():
    """A person standing still while the tracker lost the hand: the held, stale target is near
    the truth (RMSE 20 mm), but the robot imitated nothing on 60 % of the ticks -- the verdict
    says so instead of "ok"; a target never lost keeps the plain RMSE / lag line."""
    site = {"status": "lost_often", "target": "right_hand", "rmse_mm": 20.0, "lag_ms": 10.0,
            "lost_fraction": 0.6, "reason": "right_hand lost on 60% of the ticks"}
    v = {x.label: x for x in verdicts({"mimicry": {"R_palm": site}})}["mimicry R_palm: RMSE / lag"]
    assert v.status == "bad"
    assert "right_hand lost on 60% of the ticks" in v.value and "lost ok ≤ 0.05" in v.threshold
    some = {x.label: x for x in verdicts({"mimicry": {"R_palm": site | {
        "status": "ok", "lost_fraction": 0.1}}})}["mimicry R_palm: RMSE / lag"]
    assert some.status == "warn"
    fine = {x.label: x for x in verdicts({"mimicry": {"R_palm": site | {
        "status": "ok", "lost_fraction": 0.0}}})}["mimicry R_palm: RMSE / lag"]
    assert (fine.status, fine.value) == ("ok", "20.0 mm / 10 ms")
    assert fine.threshold == "RMSE ok ≤ 25, warn ≤ 50; |lag| ok ≤ 50, warn ≤ 100"


def test_a_person_out_of_view_gets_a_warning_line_only_when_it_happens():
    view = {"warning": "the scripted person ...", "out_of_view_fraction": 0.459,
            "first_out_of_view_s": 3.3, "min_front_distance_m": -1.68,
            "min_front_distance_t_s": 6.0}
    items = {v.label: v for v in verdicts({"person_view": view})}
    assert items["person in view"].status == "warn"
    assert items["person in view"].value == (
        "out of the eyes' start view on 46% of the run (from 3.3 s); 1.68 m behind the eyes "
        "at 6.0 s: walks through the robot")
    assert "person in view" not in {v.label for v in verdicts({"person_view": view | {
        "warning": None, "out_of_view_fraction": 0.0}})}
