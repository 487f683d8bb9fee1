"""Mimicry scores against closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from humimic.maths.stats import rmse
from humimic.metrics.mimicry import (
    LOST_OFTEN,
    TERMS,
    add_budget_sums,
    budget_from_sums,
    budget_sums,
    error_terms,
    head_motion,
    image_offsets,
    lost_status,
    mse_shares,
    rms_jerk,
    stale_time,
    summary_stats,
    xcorr_lag,
)
from humimic.sensors.camera_model import Intrinsics

DT = 1.0 / 420.0


@pytest.mark.parametrize("delay", [0.0123, -0.0071, 0.0])
def test_xcorr_lag_recovers_a_subsample_delay(delay):
    t = np.arange(0, 6, DT)
    w1, w2 = 2 * np.pi * 0.5, 2 * np.pi * 0.83
    ref = np.stack([np.sin(w1 * t), 0.5 * np.cos(w2 * t), 0.2 * np.sin(w2 * t + 1)], axis=1)
    tt = t - delay
    sig = np.stack([np.sin(w1 * tt), 0.5 * np.cos(w2 * tt), 0.2 * np.sin(w2 * tt + 1)], axis=1)
    # measured <= 1.7e-7 s off (these and three other delays; 2026-11-29; the bound was 2e-4)
    assert xcorr_lag(ref, sig, DT) == pytest.approx(delay, abs=5e-7)


def test_rms_jerk_of_a_sine():
    """x = A sin(w t): jerk = -A w^3 cos(w t), RMS A w^3 / sqrt(2)."""
    t = np.arange(0, 4, DT)
    A, w = 0.2, 2 * np.pi * 0.5
    p = np.stack([A * np.sin(w * t), np.zeros_like(t), np.zeros_like(t)], axis=1)
    # measured 4.2e-8 off (2026-11-29; the bound was 1 %)
    assert rms_jerk(p, DT) == pytest.approx(A * w**3 / np.sqrt(2), rel=1e-7)


def test_error_terms_are_the_stage_differences():
    """Each term is one stage's output minus its input (e.g. the IK's residual is the IK's
    site minus the command), on the ground-truth time grid."""
    rng = np.random.default_rng(0)
    (true_now, true_photon, true_ready, true_stale, est, cmd_raw, cmd, ik,
     robot) = (rng.normal(size=(50, 3)) for _ in range(9))
    terms = error_terms(true_now, true_photon, true_ready, true_stale, est, cmd_raw, cmd, ik,
                        robot)
    assert list(TERMS) == ["estimate", "pipeline_delay", "fresh_hold", "stale_hold",
                           "interpolation", "workspace", "ik", "servo"]
    np.testing.assert_array_equal(terms["ik"], ik - cmd)
    np.testing.assert_array_equal(terms["pipeline_delay"], true_photon - true_ready)
    np.testing.assert_array_equal(terms["stale_hold"], true_stale - true_now)
    np.testing.assert_array_equal(terms["total"], robot - true_now)
    np.testing.assert_allclose(sum(terms[k] for k in TERMS), terms["total"], atol=1e-12)


def test_a_held_estimate_s_age_splits_into_delay_fresh_and_stale_hold():
    """A target moving at constant velocity v, its last estimate (photon time 1.0 s, ready
    30 ms later) held until 1.6 s while the target is lost after MAX_AGE = 0.25 s: the
    pipeline's delay is v * 30 ms, the fresh hold v * 220 ms and the stale hold v * 350 ms --
    the old single "latency" term (v * 600 ms) was mostly a lost target's, not a latency.
    Before the estimate goes stale (now 1.1 s) the stale hold is exactly zero."""
    v = np.array([0.2, -0.1, 0.05])
    truth = lambda t: np.outer(np.atleast_1d(t), v)  # noqa: E731
    t_photon, t_ready = np.array([1.0, 1.0]), np.array([1.03, 1.03])
    t_now = np.array([1.6, 1.1])
    t_stale = stale_time(t_now, t_photon, t_ready, 0.25)
    np.testing.assert_allclose(t_stale, [1.25, 1.1])
    est = truth(t_photon)
    terms = error_terms(truth(t_now), truth(t_photon), truth(t_ready), truth(t_stale), est,
                        est, est, est, est)
    np.testing.assert_allclose(terms["pipeline_delay"], -np.outer([0.03, 0.03], v), atol=1e-12)
    np.testing.assert_allclose(terms["fresh_hold"], -np.outer([0.22, 0.07], v), atol=1e-12)
    np.testing.assert_allclose(terms["stale_hold"], -np.outer([0.35, 0.0], v), atol=1e-12)
    np.testing.assert_allclose(terms["total"], -np.outer([0.6, 0.1], v), atol=1e-12)


def test_lost_often_names_the_target_and_its_share():
    assert lost_status(LOST_OFTEN, "right_hand", 0.25) == {"status": "ok"}
    s = lost_status(0.6, "right_hand", 0.25)
    assert s["status"] == "lost_often"
    assert "right_hand lost on 60% of the ticks" in s["reason"]


def test_mse_shares_against_closed_forms():
    """Orthogonal terms share the mean square by their own squares; a term that cancels
    another gets a negative share."""
    n = 40
    z = np.zeros((n, 3))
    a, b = z.copy(), z.copy()
    a[:, 0], b[:, 1] = 1.0, 2.0
    terms = {k: z for k in TERMS} | {"estimate": a, "servo": b, "total": a + b}
    s = mse_shares(terms)
    assert s["estimate"] == pytest.approx(1 / 5) and s["servo"] == pytest.approx(4 / 5)
    terms = {k: z for k in TERMS} | {"fresh_hold": 2 * a, "interpolation": -a, "total": a}
    s = mse_shares(terms)
    assert s["fresh_hold"] == pytest.approx(2.0) and s["interpolation"] == pytest.approx(-1.0)


def _whole_run_budget(terms):
    """The budget as computed on whole arrays, independently of budget_sums: rmse per term,
    shares from their definition, the largest error norm."""
    total = terms["total"]
    ok = np.all(np.isfinite(total), axis=1)
    for name in TERMS:
        ok &= np.all(np.isfinite(terms[name]), axis=1)
    ms = np.einsum("ij,ij->", total[ok], total[ok])
    shares = {name: np.einsum("ij,ij->", terms[name][ok], total[ok]) / ms for name in TERMS}
    return ({name: rmse(terms[name]) for name in (*TERMS, "total")}, shares,
            np.max(np.sqrt(np.einsum("ij,ij->i", total, total))))


@pytest.mark.parametrize("with_nan", [False, True])
def test_budget_summed_over_blocks_equals_the_whole_arrays(with_nan):
    """A long run is scored block by block: the sums of uneven blocks give each term's RMS
    (humimic.maths.stats.rmse on the whole array), the shares and the largest error to
    rounding (rel 1e-12; the sums are only grouped differently)."""
    rng = np.random.default_rng(3)
    n = 10_007
    parts = {k: rng.normal(scale=s, size=(n, 3)) for k, s in
             zip(("true_now", "true_photon", "est", "cmd_raw", "cmd", "ik", "robot"),
                 (0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1), strict=True)}
    parts |= {k: rng.normal(scale=0.1, size=(n, 3)) for k in ("true_ready", "true_stale")}
    if with_nan:  # rows a term was not measured in (e.g. lost estimates): skipped per term
        parts["est"][rng.choice(n, 300, replace=False), 1] = np.nan
    terms = error_terms(**parts)
    rms, shares, top = _whole_run_budget(terms)
    if with_nan:  # the total has no NaN: its max is finite, the shares skip the NaN rows
        assert np.isfinite(top)
    sums = None
    edges = [0, 1, 4096, 4097, 9000, n]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sums = add_budget_sums(sums, budget_sums({k: v[a:b] for k, v in terms.items()}))
    b_rms, b_shares, b_top = budget_from_sums(sums)
    for name in rms:
        assert b_rms[name] == pytest.approx(rms[name], rel=1e-12)
    for name in TERMS:
        assert b_shares[name] == pytest.approx(shares[name], rel=1e-9, abs=1e-12)
    assert sum(b_shares.values()) == pytest.approx(1.0, rel=1e-12)
    assert b_top == top  # a max is exact


def test_budget_sums_of_no_rows_and_nan_rows():
    z = np.zeros((0, 3))
    rms, shares, top = budget_from_sums(budget_sums({k: z for k in (*TERMS, "total")}))
    assert all(np.isnan(v) for v in (*rms.values(), *shares.values(), top))
    one = np.ones((4, 3))
    nan = one.copy()
    nan[2] = np.nan
    sums = add_budget_sums(budget_sums({k: one for k in (*TERMS, "total")}),
                           budget_sums({k: nan for k in (*TERMS, "total")}))
    assert np.isnan(budget_from_sums(sums)[2])  # as np.max over the whole array


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
