"""The one-page run report: NEES maths against independent computations, the page for a
finished run, and exit 2 for a directory that is not a run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from humimic.paths import SCENARIOS_DIR
from humimic.report.__main__ import main as report_main
from humimic.report.nees import chi2_bounds, moving_mean, nees
from humimic.report.page import verdicts
from humimic.run import run_one
from humimic.scenario import load_scenario


def test_nees_of_a_diagonal_covariance_is_the_sum_of_squared_z_scores():
    rng = np.random.default_rng(0)
    e = rng.normal(size=(50, 3))
    sig = rng.uniform(0.5, 2.0, size=(50, 3))
    P = np.stack([np.diag(s**2) for s in sig])
    assert np.allclose(nees(e, P), ((e / sig) ** 2).sum(axis=1))


def test_nees_bounds_hold_95_percent_of_consistent_windows():
    """Monte Carlo: errors drawn from P give window means inside the bounds ~95 % of the time."""
    rng = np.random.default_rng(1)
    n, window, dof = 21_000, 30, 9
    A = rng.normal(size=(dof, dof))
    P = A @ A.T + dof * np.eye(dof)
    e = rng.multivariate_normal(np.zeros(dof), P, size=n)
    values = nees(e, np.broadcast_to(P, (n, dof, dof)))
    assert values.mean() == pytest.approx(dof, rel=0.02)
    lo, hi = chi2_bounds(dof, window)
    means = values.reshape(-1, window).mean(axis=1)
    inside = np.mean((means >= lo) & (means <= hi))
    assert 0.93 < inside < 0.97
    # an overconfident filter (P four times too small) falls outside
    over = nees(e, np.broadcast_to(P / 4, (n, dof, dof))).reshape(-1, window).mean(axis=1)
    assert np.mean((over >= lo) & (over <= hi)) < 0.01


def test_moving_mean_matches_a_loop_and_skips_nan():
    x = np.array([1.0, np.nan, 3.0, 5.0, np.nan, 7.0, 2.0])
    n = 3
    expected = []
    for k in range(len(x)):
        w = x[max(0, k - n + 1):k + 1]
        w = w[np.isfinite(w)]
        expected.append(w.mean() if len(w) else np.nan)
    assert np.allclose(moving_mean(x, n), expected, equal_nan=True)


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


@pytest.mark.slow
def test_report_of_a_finished_tracked_run(tmp_path, capsys):
    scenario = load_scenario(SCENARIOS_DIR / "mimic_tracked_wave.yaml", duration=1.6)
    run_one(scenario, tmp_path, rerun="off", progress=False)  # writes the report itself
    for name, size in (("report.png", 50_000), ("report.html", 3_000)):
        assert (tmp_path / name).stat().st_size > size
        (tmp_path / name).unlink()
    assert report_main([str(tmp_path)]) == 0
    page = (tmp_path / "report.html").read_text()
    assert "right_hand: detection rate" in page and "χ² bounds" in page
    assert (tmp_path / "report.png").stat().st_size > 50_000


def test_report_refuses_a_directory_that_is_not_a_run(tmp_path, capsys):
    assert report_main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not a humimic run directory" in err and len(err.splitlines()) == 1
    (tmp_path / "metrics.json").write_text("{not json")
    assert report_main([str(tmp_path)]) == 2
    assert "unreadable metrics.json" in capsys.readouterr().err
