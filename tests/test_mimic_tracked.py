"""Mimicry through the tracked perception pipeline (blob tracker + stereo + random-jerk Kalman
filter at 60 Hz, wide cameras, 320x240), thresholds from the measured values with a 2-3x
margin; the paper's goals (RMSE <= 25 mm, lag <= 50 ms) are in the benchmark report.

Measured on 2026-11-23 (calibrated measurement noise): RMSE 15.5 mm, lag 20.9 ms (a
cross-correlation lag: the hold PD adds ~half a frame to the latency), photon-to-joint latency
16.7 ms (perception declares one frame; the estimate is used at the servo tick it is ready),
measurements 9.3 mm and estimates 8.1 mm RMS; re-measured 2026-11-29: RMSE 15.1 mm, lag 21.9 ms,
measurements 7.8 mm, estimates 6.9 mm (the bounds 2.0-2.6x these). Detection starts at once
(``detection.period: 0``) and mimicry 0.5 s later, once the filter's velocity has converged.
"""

from __future__ import annotations

import pytest

from humimic.run import run_one
from humimic.scenario import load_scenario

TRACKED = ["mimic.perception=tracked", "mimic.start=0.5", "filter={}",
           "perception={targets: [head, right_hand], detection: {period: 0.0}}",
           "output.plots=false", 'output.rerun="off"']


@pytest.mark.slow
def test_tracked_wave_accuracy_and_latency(root, tmp_path):
    sc = load_scenario(root / "scenarios" / "mimic_wave.yaml", TRACKED, duration=4.0)
    m = run_one(sc, tmp_path, rerun="off", progress=False)
    palm = m["mimicry"]["R_palm"]
    assert palm["status"] == "ok", palm
    assert palm["rmse_mm"] <= 35.0
    assert 0.0 < palm["lag_ms"] <= 45.0
    frame_ms, servo_ms = 1e3 / 60.0, 1e3 / 420.0
    lat = m["latency_ms"]
    assert lat["perception"] == pytest.approx(frame_ms) and lat["filter"] == 0.0
    assert frame_ms <= lat["end_to_end"] <= lat["end_to_end_max"] < frame_ms + servo_ms
    assert m["mimicry"]["joints"]["limit_violations"] == 0
    assert palm["estimates_rmse_mm"] < palm["measurements_rmse_mm"] <= 20.0  # the filter helps
