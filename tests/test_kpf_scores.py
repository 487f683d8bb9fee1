"""``truth_margin_scores`` (the kpf's likelihood at the truth against its estimate) against a
plain-Python count over the finite frames."""

from __future__ import annotations

import math

import numpy as np

from humimic.perception.trackers.kpf.scores import truth_margin_scores


def test_truth_margin_scores_match_a_plain_count():
    rng = np.random.default_rng(0)
    m = rng.normal(0.3, 1.0, 200)
    m[rng.random(200) < 0.1] = np.nan
    got = truth_margin_scores(m)
    finite = [float(x) for x in m if not math.isnan(x)]
    assert math.isclose(got["truth_margin_nats"], sum(finite) / len(finite), rel_tol=1e-12)
    assert got["estimate_above_truth_fraction"] == sum(x < 0 for x in finite) / len(finite)
    assert truth_margin_scores(np.full(3, np.nan)) == {
        "truth_margin_nats": None, "estimate_above_truth_fraction": None}
