"""Mimicry scores against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.metrics.mimicry import (
    TERMS,
    error_terms,
    head_motion,
    image_offsets,
    rms_jerk,
    rmse,
    summary_stats,
    xcorr_lag,
)
from humimic.sensors.camera_model import Intrinsics

DT = 1.0 / 420.0


def test_rmse_closed_form_and_nan_rows():
    a = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0], [np.nan, 0, 0]])
    assert rmse(a, np.zeros((3, 3))) == pytest.approx(np.sqrt(25 / 2))


@pytest.mark.parametrize("delay", [0.0123, -0.0071, 0.0])
def test_xcorr_lag_recovers_a_subsample_delay(delay):
    t = np.arange(0, 6, DT)
    w1, w2 = 2 * np.pi * 0.5, 2 * np.pi * 0.83
    ref = np.stack([np.sin(w1 * t), 0.5 * np.cos(w2 * t), 0.2 * np.sin(w2 * t + 1)], axis=1)
    tt = t - delay
    sig = np.stack([np.sin(w1 * tt), 0.5 * np.cos(w2 * tt), 0.2 * np.sin(w2 * tt + 1)], axis=1)
    assert xcorr_lag(ref, sig, DT) == pytest.approx(delay, abs=2e-4)


def test_rms_jerk_of_a_sine():
    """x = A sin(w t): jerk = -A w^3 cos(w t), RMS A w^3 / sqrt(2)."""
    t = np.arange(0, 4, DT)
    A, w = 0.2, 2 * np.pi * 0.5
    p = np.stack([A * np.sin(w * t), np.zeros_like(t), np.zeros_like(t)], axis=1)
    assert rms_jerk(p, DT) == pytest.approx(A * w**3 / np.sqrt(2), rel=0.01)


def test_error_terms_add_up_to_the_total():
    rng = np.random.default_rng(0)
    x = [rng.normal(size=(50, 3)) for _ in range(7)]
    terms = error_terms(*x)
    assert set(TERMS) <= set(terms)
    np.testing.assert_allclose(sum(terms[k] for k in TERMS), terms["total"], atol=1e-12)
    np.testing.assert_allclose(terms["total"], x[6] - x[0])


def test_head_motion():
    R = Rotation.from_rotvec(np.outer(np.linspace(0, 1, 5), [0, 0, np.radians(3)])).as_matrix()
    p = np.outer(np.linspace(0, 1, 5), [0.003, 0.004, 0.0])
    dp, dr = head_motion(p, R)
    assert dp == pytest.approx(0.005) and np.degrees(dr) == pytest.approx(3.0)


def test_image_offsets_match_the_projection():
    intr = Intrinsics(320, 240, 134.0, 130.0, 159.5, 119.5)
    p = np.array([[0.1, -0.2, 1.5], [0.0, 0.0, 2.0], [0.0, 0.0, -1.0]])
    uv = intr.project(p[:2])
    expect = np.hypot(uv[:, 0] - intr.cx, uv[:, 1] - intr.cy) / 320
    off = image_offsets(p, intr.fx, intr.fy, 320, 240)
    np.testing.assert_allclose(off[:2], expect)
    assert off[2] == np.inf
    assert summary_stats(off)["max"] == pytest.approx(expect.max())
