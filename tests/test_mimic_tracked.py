"""Mimicry through the tracked perception pipeline (blob tracker + stereo + random-jerk Kalman
filter at 60 Hz, wide cameras, 320x240): the issue's thresholds RMSE <= 25 mm, lag <= 50 ms,
end-to-end latency <= 50 ms.

Measured on 2026-11-22 (perception still being tuned): RMSE 19.9 mm, lag 6.3 ms, end-to-end
6.3 ms (perception and filter declare no processing latency by default). Detection starts at
once (``detection.period: 0``) and mimicry 0.5 s later, once the filter's velocity has
converged. Skipped while the perception and filter sections are not in the schema.
"""

from __future__ import annotations

import pytest

from humimic.run import run_one
from humimic.scenario import Scenario, load_scenario

TRACKED = ["mimic.perception=tracked", "mimic.start=0.5", "filter={}",
           "perception={targets: [head, right_hand], detection: {period: 0.0}}",
           "output.plots=false", 'output.rerun="off"']

pytestmark = pytest.mark.skipif(
    not {"perception", "filter"} <= set(Scenario.model_fields),
    reason="tracked perception (perception + filter stages) is not in the scenario schema yet")


@pytest.mark.slow
def test_tracked_wave_meets_the_accuracy_goals(root, tmp_path):
    sc = load_scenario(root / "scenarios" / "mimic_wave.yaml", TRACKED, duration=4.0)
    m = run_one(sc, tmp_path, rerun="off", progress=False)
    palm = m["mimicry"]["R_palm"]
    assert palm["status"] == "ok", palm
    assert palm["rmse_mm"] <= 25.0
    assert palm["lag_ms"] <= 50.0
    assert m["latency_ms"]["end_to_end"] <= 50.0
    assert m["mimicry"]["joints"]["limit_violations"] == 0
    assert palm["error_budget_mm"]["perception"] is not None
