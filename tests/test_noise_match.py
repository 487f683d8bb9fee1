"""Noise matching (``filter.noise_match``): R scaled to the measurements' own scatter."""

import numpy as np
import pytest
from scipy.spatial.distance import mahalanobis

from humimic.estimation.config import FilterConfig
from humimic.estimation.noise_match import (
    NoiseMatch,
    noise_ratio,
    second_difference_ratios,
)
from humimic.estimation.stage import FilterRecord, FilterStage
from humimic.messages import Measurement, Measurements

DT = 1.0 / 60.0
R0 = np.array([[4.0, 1.0, 0.5], [1.0, 2.0, 0.3], [0.5, 0.3, 9.0]]) * 1e-6  # m^2, mm-sized


def _track(n: int, k2: float, rng: np.random.Generator):
    """A point moving at constant velocity, measured with noise k2 * R0."""
    t = np.arange(n) * DT
    p = np.array([1.2, 0.1, 1.3]) + np.outer(t, [0.3, -0.8, 0.5])
    z = p + rng.multivariate_normal(np.zeros(3), k2 * R0, size=n)
    return t, z, np.broadcast_to(R0, (n, 3, 3)).copy(), p


def test_ratios_are_the_second_differences_mahalanobis_squared_over_3():
    rng = np.random.default_rng(0)
    t, z, R, _ = _track(6, 1.0, rng)
    R[2] *= 3.0  # a measurement with its own R
    q = second_difference_ratios(t, z, R)
    for k in range(1, 5):
        d = z[k - 1] - 2 * z[k] + z[k + 1]
        S = R[k - 1] + 4 * R[k] + R[k + 1]
        assert q[k - 1] == pytest.approx(mahalanobis(d, np.zeros(3), np.linalg.inv(S)) ** 2 / 3)


@pytest.mark.parametrize("k2", [1.0, 49.0])
def test_the_ratio_estimates_how_much_the_noise_exceeds_r(k2):
    """Measured (seed 1, 3000 frames): 0.98 and 47.8 for the true 1 and 49."""
    t, z, R, _ = _track(3000, k2, np.random.default_rng(1))
    assert noise_ratio(t, z, R) == pytest.approx(k2, rel=0.1)


def test_a_jump_or_a_missed_frame_does_not_count():
    t, z, R, _ = _track(12, 1.0, np.random.default_rng(2))
    z[6:] += 0.05  # the target moved by 50 mm (~25 sigma): two triples see it
    assert noise_ratio(t, z, R) < 4.0  # measured 2.03 (the median of ten triples)
    keep = np.r_[0:5, 6:12]  # frame 5 missed: the two triples across the gap are left out
    assert len(second_difference_ratios(t[keep], z[keep], R[keep])) == 7


def test_below_the_threshold_r_is_used_as_given():
    match = NoiseMatch(threshold=8.0)
    t, z, R, _ = _track(200, 1.0, np.random.default_rng(3))
    assert [match.scale(*a) for a in zip(t, z, R, strict=True)] == [1.0] * 200
    assert match.scaled == 0


def _still_head(cfg: FilterConfig, noise_std: float, seed: int = 0):
    """A still target 1.3 m away measured for 4 s with ``noise_std`` (m) per axis while R
    says 3 mm: the head in a shirt of nearly the skin's colour (ude_wave_tracking seed 31,
    lab_clutter: raw 43 mm, R ~7x too small in standard deviation)."""
    rng = np.random.default_rng(seed)
    stage = FilterStage(cfg, ["head"], FilterRecord(["head"]))
    p, R = np.array([1.3, 0.0, 1.6]), (0.003**2) * np.eye(3)
    for k in range(240):
        z = p + rng.normal(scale=noise_std, size=3)
        stage.step(k * DT, Measurements({"head": Measurement("head", z, R)}))
    a = stage.record.arrays()
    err = np.linalg.norm(a.x[:, 0, 0:3] - p, axis=1)
    settled = a.measured[:, 0] & (a.since_init[:, 0] >= 0.5)
    return err, settled, stage.metrics()["filter"]


def test_noise_far_above_r_no_longer_re_initialises_the_filter_every_few_frames():
    err, settled, m = _still_head(FilterConfig(), 0.02)
    old_err, old_settled, old = _still_head(FilterConfig(noise_match=None), 0.02)
    # without: re-initialised every few frames, never 0.5 s old (measured, seeds 0-2: 45-46
    # re-inits, 0 settled frames, RMS error of the estimates 128-130 mm against 35 mm raw)
    assert old["gate_reinits"]["head"] > 20 and not old_settled.any()
    # with: measured 1 re-init (before the window fills), 204-205 settled frames, RMS error
    # 23-25 mm settled, 26-34 mm over all estimates; 234 of 240 measurements scaled
    assert np.sqrt(np.mean(err**2)) < 0.5 * np.sqrt(np.mean(old_err**2))
    assert m["gate_reinits"]["head"] <= 2 and settled.sum() > 150
    assert np.sqrt(np.mean(err[settled] ** 2)) < 0.05
    assert m["noise_scaled_frames"]["head"] > 150


def test_honest_r_gives_the_same_estimates_bit_for_bit():
    err, _, m = _still_head(FilterConfig(), 0.003)
    old_err, _, _ = _still_head(FilterConfig(noise_match=None), 0.003)
    assert m["noise_scaled_frames"]["head"] == 0
    np.testing.assert_array_equal(err, old_err)
