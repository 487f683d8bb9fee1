"""Tracking scores, the Table 2/3 computations and the record archive, against direct
computations on hand-made records."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from _synth_vision import stereo_head

from humimic import spill
from humimic.estimation.stage import FilterArrays, FilterRecord
from humimic.metrics.tracking import (
    axis_stats,
    detection_stats,
    filtered_scores,
    raw_scores,
)
from humimic.metrics.ude_tables import filter_white_noise, table2, table3
from humimic.perception.blobs import archive as archive_mod
from humimic.perception.blobs.archive import load_archive, read_rows, save_archive
from humimic.perception.blobs.record import STATE_CODE, PerceptionArrays, PerceptionRecord
from humimic.perception.blobs.stereo import StereoRig
from humimic.sensors.visibility import VisibilityArrays

S, T, L = (STATE_CODE[k] for k in ("searching", "tracking", "lost"))


def test_axis_statistics_match_numpy():
    rng = np.random.default_rng(0)
    e = rng.normal(size=(50, 3))
    bias, std = axis_stats(e, 1e3)
    np.testing.assert_allclose(bias, 1e3 * e.mean(0))
    np.testing.assert_allclose(std, 1e3 * e.std(0))
    assert axis_stats(np.zeros((0, 3))) == ([None] * 3, [None] * 3)


def test_detection_statistics_by_hand():
    t = np.arange(12) / 60.0
    ok = np.array([0, 0, 0, 1, 1, 0, 1, 0, 0, 0, 1, 1], bool)
    state = np.array([S, S, S, T, T, T, T, L, L, L, T, T])
    d = detection_stats(t, ok, state)
    assert d["detection_rate"] == pytest.approx(5 / 9)  # from the first measured frame on
    assert d["detection_rate_all"] == pytest.approx(5 / 12)
    assert d["time_to_first_detection_s"] == pytest.approx(3 / 60)
    assert (d["losses"], d["reacquisitions"], d["measured_frames"]) == (1, 1, 5)
    never = detection_stats(t, np.zeros(12, bool), np.full(12, S))
    assert never["detection_rate"] == 0.0 and never["time_to_first_detection_s"] is None


def _record(n=40, offset_px=(0.3, -0.4), seed=0):
    """A static point seen by a synthetic stereo head; left centres offset by ``offset_px``."""
    rng = np.random.default_rng(seed)
    cam_l, cam_r = stereo_head(k1=0.0, k2=0.0)
    p = np.array([1.0, 0.1, 1.3])
    rec = PerceptionRecord(["hand"], ("L", "R"), (cam_l.intrinsics, cam_r.intrinsics))
    rig = StereoRig(cam_l, cam_r)
    for k in range(n):
        ul = cam_l.project_base(p) + offset_px
        ub = cam_r.project_base(p) + offset_px  # the right blob's centre
        ur = ub + [rng.normal(0, 0.05), 0.0]  # the stereo match (noisy along the line)
        q, R = rig.triangulate(ul, ur, 0.09 * np.eye(2), 0.09 * np.eye(2))
        rec.append(k / 60.0, np.stack([cam_l.T_base_cam, cam_r.T_base_cam]), np.array([T]),
                   np.ones((1, 2), bool), np.ones(1, bool), np.array([[ul, ub]]),
                   np.ones((1, 2, 2, 2)) * np.eye(2) * 9.0, np.ones(1, bool), [""], q[None],
                   R[None], np.array([[ul, ur]]), np.ones(1))
    return rec.arrays(), p


def test_raw_scores_and_pixel_error():
    pa, p = _record()
    truth = np.repeat(p[None], len(pa.t), 0)
    r = raw_scores(pa, 0, truth)
    assert r["pixel_rmse"] == pytest.approx(0.5, rel=1e-6)  # |(0.3, -0.4)| in both eyes
    err = pa.p_base[:, 0] - truth
    assert r["raw_rmse_mm"] == pytest.approx(1e3 * math.sqrt(np.mean(np.sum(err**2, 1))))
    np.testing.assert_allclose(r["raw_std_mm"], 1e3 * err.std(0))


def test_filtered_scores_skip_start_up_and_split_predictions():
    n = 30
    t = np.arange(n) / 60.0
    x = np.zeros((n, 1, 9))
    x[:, 0, 0] = 0.002  # 2 mm off in x, v and a exact
    valid = np.ones((n, 1), bool)
    measured = valid.copy()
    measured[20:25] = False  # prediction only
    x[20:25, 0, 1] = 0.05  # predicted frames 50 mm off in y
    since = t[:, None].copy()
    fa = FilterArrays(["hand"], t, valid, measured, x, np.broadcast_to(np.eye(9) * 1e-6,
                      (n, 1, 9, 9)).copy(), since)
    z = np.zeros((n, 3))
    s = filtered_scores(fa, 0, z, z, z, settle_s=10 / 60 - 1e-9)
    assert s["scored_estimates"] == 15  # frames 10..29 measured, minus 20..24
    assert s["filtered_rmse_mm"] == pytest.approx(2.0)
    assert s["vel_rmse_mm_s"] == 0.0 and s["acc_rmse_mm_s2"] == 0.0
    assert s["predicted_frames"] == 5
    assert s["predicted_rmse_mm"] == pytest.approx(math.hypot(2.0, 50.0))
    assert s["filtered_nees_pos3"] == pytest.approx((0.002**2) / 1e-6)  # 4: inside the band
    assert s["filtered_nees_pos3_in_band"] == 1.0
    assert s["filtered_nees_pva9"] == pytest.approx((0.002**2) / 1e-6)


def test_raw_scores_flag_a_bias_larger_than_the_noise():
    """Measurements 20 mm in front of the truth (a surface, not the centre) with noise that R
    describes exactly: the target is flagged biased, its NEES against the truth leaves the
    chi-square band, with the bias removed 95 % of the frames are inside it."""
    pa, p = _record(n=5)
    n = 2000
    C = np.diag([4e-6, 1e-6, 1e-6])  # 2 mm in depth (base x), 1 mm across
    rng = np.random.default_rng(5)
    meas = p + np.array([-0.02, 0.0, 0.0]) + rng.normal(size=(n, 3)) @ np.sqrt(C)
    pa = dataclasses.replace(
        pa, t=np.arange(n) / 60.0, ok=np.ones((n, 1), bool), p_base=meas[:, None],
        R_base=np.broadcast_to(C, (n, 1, 3, 3)), seen=np.zeros((n, 1, 2), bool),
        confirmed=np.zeros((n, 1), bool))
    r = raw_scores(pa, 0, np.repeat(p[None], n, 0))
    assert r["biased"] and r["raw_bias_share"] == pytest.approx(400 / 406, abs=0.01)
    assert r["raw_nees_pos3"] == pytest.approx(3 + 400 / 4, rel=0.05)
    assert r["raw_nees_pos3_in_band"] < 0.01
    assert r["raw_nees_pos3_debiased_in_band"] == pytest.approx(0.95, abs=0.015)


def test_white_noise_filtering_gives_the_papers_table3_with_b_1():
    """Ude & Atkeson's Table 3 (filtered/raw 0.61/0.50/0.48, velocity spread 25-92 mm/s) is
    what the random-jerk filter makes of white noise of its raw spread with b ~ 1 m s^-2.5,
    not with its stated 27.5 (4-6x the velocity and ~13x the acceleration spread)."""
    raw = np.array([2.96, 7.92, 35.0])
    b1, b27 = filter_white_noise(raw, 1.0), filter_white_noise(raw, 27.5)
    ratio = b1["filtered_std"] / raw
    np.testing.assert_allclose(ratio, [0.61, 0.50, 0.48], atol=0.07)  # measured .58 .48 .43
    np.testing.assert_allclose(b1["vel_std"], [25.0, 28.3, 91.8], rtol=0.35)  # 23 37 88
    assert np.all(b27["vel_std"] > 3.5 * b1["vel_std"])  # measured 4.5-4.9x
    assert np.all(b27["acc_std"] > 10 * b1["acc_std"])  # measured 14-16x


def test_table3_in_the_camera_frame_and_table2_shapes():
    pa, p = _record(n=60, seed=1)
    x = np.zeros((len(pa.t), 9))
    x[:, :3] = pa.p_base[:, 0]
    r = table3(pa, "hand", x, np.full(len(pa.t), 10.0), skip_s=0.0)
    T_cb = np.linalg.inv(pa.T_base_cam[0, 0])
    cam = pa.p_base[:, 0] @ T_cb[:3, :3].T + T_cb[:3, 3]
    np.testing.assert_allclose(r["raw_mean"], 1e3 * cam.mean(0))
    np.testing.assert_allclose(r["raw_std"], 1e3 * cam.std(0))
    assert r["raw_std"][2] > 10 * r["raw_std"][0]  # depth noise dominates: measured 27.6x
    t2 = table2(pa, "hand", skip_s=0.0)
    assert t2.n == 60 and t2.empirical.shape == (3, 3)
    # measured 1.6 % off (seeds 1-4: 1.5-1.8 %; 2026-11-29; the bound was 35 %)
    assert t2.propagated_following[2, 2] == pytest.approx(t2.empirical[2, 2], rel=0.05)


def test_archive_round_trip(tmp_path):
    pa, p = _record(n=5)
    fa = FilterArrays(["hand"], pa.t, np.ones((5, 1), bool), np.ones((5, 1), bool),
                      np.arange(45.0).reshape(5, 1, 9), np.zeros((5, 1, 9, 9)), np.ones((5, 1)))
    truth = {"hand": (np.ones((5, 3)), np.zeros((5, 3)), np.zeros((5, 3)))}
    vis = VisibilityArrays(["L", "R"], ["hand"], np.array([0.0, 0.2]),
                           np.array([[[30.0], [0.0]], [[12.0], [40.0]]]),
                           np.array([[[40.0], [0.0]], [[48.0], [40.0]]]))
    save_archive(tmp_path / "a.npz", pa, fa, truth, truth, vis)
    back = load_archive(tmp_path / "a.npz")
    assert back.visibility.cameras == ["L", "R"] and back.visibility.targets == ["hand"]
    np.testing.assert_array_equal(back.visibility.unoccluded[:, :, 0], [[0.75, 0.0], [0.25, 1]])
    save_archive(tmp_path / "b.npz", pa, fa, truth, truth)  # a run without visibility
    assert load_archive(tmp_path / "b.npz").visibility is None
    np.testing.assert_array_equal(back.perception.p_base, pa.p_base)
    np.testing.assert_array_equal(back.perception.uv_match, pa.uv_match)
    assert back.perception.reason.tolist() == pa.reason.tolist()
    assert back.perception.intrinsics == pa.intrinsics and back.perception.cameras == ("L", "R")
    np.testing.assert_array_equal(back.filter.x, fa.x)
    np.testing.assert_array_equal(back.filter_truth["hand"][0], truth["hand"][0])
    assert back.perception.camera(2, 1).T_base_cam.shape == (4, 4)


def test_read_rows_streams_a_column_as_numpy_slices_it(tmp_path, monkeypatch):
    """A target's column read a few rows at a time equals the whole array sliced by numpy
    (blocks that do not divide the rows, float and bool, and an array stored Fortran-order)."""
    monkeypatch.setattr(archive_mod, "READ_BLOCK", 7)
    rng = np.random.default_rng(1)
    P = rng.normal(size=(30, 2, 9, 9))
    valid = rng.random((30, 2)) > 0.5
    np.savez_compressed(tmp_path / "r.npz", P=P, valid=valid, F=np.asfortranarray(P[:, 0, 0]),
                        empty=np.zeros((0, 2, 3)))
    np.testing.assert_array_equal(read_rows(tmp_path / "r.npz", "P", lambda a: a[:, 1, :3, :3]),
                                  P[:, 1, :3, :3])
    np.testing.assert_array_equal(read_rows(tmp_path / "r.npz", "valid", lambda a: a[:, 0]),
                                  valid[:, 0])
    np.testing.assert_array_equal(read_rows(tmp_path / "r.npz", "F", lambda a: a[:, 2:]),
                                  P[:, 0, 0, 2:])
    assert read_rows(tmp_path / "r.npz", "empty", lambda a: a[:, 1]).shape == (0, 3)


def _records(n: int, seed: int = 2):
    """Two-target perception and filter records of ``n`` random frames (reasons of varying
    length, as a run's are)."""
    rng = np.random.default_rng(seed)
    prec = PerceptionRecord(["head", "hand"], ("L", "R"), None)
    frec = FilterRecord(["head", "hand"])
    for k in range(n):
        prec.append(k / 60.0, rng.normal(size=(2, 4, 4)), rng.integers(0, 3, 2),
                    rng.random((2, 2)) > 0.5, rng.random(2) > 0.5, rng.normal(size=(2, 2, 2)),
                    rng.normal(size=(2, 2, 2, 2)), rng.random(2) > 0.3,
                    ["", "not_seen" if k % 3 else "epipolar_mismatch_far"],
                    rng.normal(size=(2, 3)), rng.normal(size=(2, 3, 3)),
                    rng.normal(size=(2, 2, 2)), rng.random(2))
        frec.rows.append((k / 60.0, rng.random(2) > 0.2, rng.random(2) > 0.5,
                          rng.normal(size=(2, 9)), rng.normal(size=(2, 9, 9)), rng.random(2)))
    return prec, frec


def test_archive_streamed_from_the_records_equals_the_stacked_one(tmp_path, monkeypatch):
    """Records spilled over several batches: the archive written from their rows batch by
    batch holds exactly what the stacked arrays' archive holds, and one target's arrays are
    the whole arrays' columns of that target."""
    monkeypatch.setattr(spill, "BATCH", 16)
    monkeypatch.setattr(spill, "BLOCK", 7)  # columns read back 7 rows at a time
    prec, frec = _records(50)
    pa, fa = prec.arrays(), frec.arrays()
    truth = {"hand": (np.ones((50, 3)), np.zeros((50, 3)), np.zeros((50, 3)))}
    save_archive(tmp_path / "arrays.npz", pa, fa, truth, truth)
    save_archive(tmp_path / "records.npz", prec, frec, truth, truth)
    with np.load(tmp_path / "arrays.npz") as a, np.load(tmp_path / "records.npz") as r:
        assert sorted(a.files) == sorted(r.files)
        for key in a.files:
            assert a[key].dtype == r[key].dtype, key
            np.testing.assert_array_equal(a[key], r[key], err_msg=key)
    one, f_one = prec.arrays(["hand"]), frec.arrays(["hand"])
    assert one.targets == ["hand"] and f_one.targets == ["hand"]
    for f in dataclasses.fields(PerceptionArrays)[4:]:
        full = getattr(pa, f.name)
        want = full if f.name == "T_base_cam" else full[:, 1:]
        np.testing.assert_array_equal(getattr(one, f.name), want, err_msg=f.name)
    np.testing.assert_array_equal(f_one.P, fa.P[:, 1:])
    np.testing.assert_array_equal(f_one.since_init, fa.since_init[:, 1:])


def test_fraction_above_band_counts_errors_larger_than_their_covariance():
    """Gaussian errors of the stated covariance: 2.5 % above the 95 % band; twice as large
    (4x the variance): most of them above; half as large: none above (but outside the band)."""
    from scipy.stats import chi2

    from humimic.maths.stats import fraction_above_band, fraction_in_band

    rng = np.random.default_rng(2)
    v = chi2.rvs(3, size=20000, random_state=rng)
    assert fraction_above_band(v, 3) == pytest.approx(0.025, abs=0.004)
    assert fraction_above_band(4 * v, 3) == pytest.approx(np.mean(4 * v > chi2.ppf(0.975, 3)))
    assert fraction_above_band(4 * v, 3) > 0.4
    assert fraction_above_band(v / 4, 3) == 0.0 and fraction_in_band(v / 4, 3) < 0.9
    assert np.isnan(fraction_above_band([np.nan], 3))
