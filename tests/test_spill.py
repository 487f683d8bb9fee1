"""SpillArray against a plain numpy array written the same way."""

from __future__ import annotations

import numpy as np

from humimic import spill


def test_spill_array_matches_numpy(monkeypatch):
    monkeypatch.setattr(spill, "BLOCK", 8)
    n, rng = 53, np.random.default_rng(0)
    ref = np.full((n, 2, 3), np.nan)
    a = spill.SpillArray(n, (2, 3), fill=np.nan)
    flags = spill.SpillArray(n, (2,), bool, False)
    ref_flags = np.zeros((n, 2), bool)
    for k in range(41):  # rows 41.. never written
        row = rng.standard_normal((2, 3))
        a[k] = row
        ref[k] = row
        a[k, 1] = ref[k, 1] = 2 * row[1]
        flags[k, k % 2] = ref_flags[k, k % 2] = True
    for key in (0, 17, -1, slice(None), slice(3, 40), (slice(5, 45), 1), (slice(None), 0, 2),
                (9, 1), slice(2, 50, 7), np.array([40, 3, 12]), slice(30, 30),
                (slice(4, 44), np.array([1, 0])), (slice(3, 20), 0, None)):
        np.testing.assert_array_equal(a[key], ref[key])
    np.testing.assert_array_equal(flags[:41].mean(axis=0), ref_flags[:41].mean(axis=0))
    np.testing.assert_array_equal(np.asarray(a), ref)
    assert a.shape == ref.shape and len(a) == n
    assert a.truncate(41).shape == (41, 2, 3)
    np.testing.assert_array_equal(a[:], ref[:41])


def test_spill_rows_stack_like_a_list(monkeypatch):
    monkeypatch.setattr(spill, "BATCH", 4)
    rng = np.random.default_rng(2)
    rows = [(float(k), rng.standard_normal((2, 3)),
             ["", "lost"][k % 2] if k < 8 else "no stereo match", k % 3 == 0)
            for k in range(11)]  # a later batch with longer strings: the column widens
    log = spill.SpillRows()
    for r in rows:
        log.append(r)
    assert len(log) == 11 and [r[0] for r in log] == [r[0] for r in rows]
    for got, want in zip(log.columns(), zip(*rows, strict=True), strict=True):
        np.testing.assert_array_equal(got, np.array(want))
        assert got.dtype == np.array(want).dtype


def test_row_blocks_cover_the_rows_block_by_block(monkeypatch):
    monkeypatch.setattr(spill, "BLOCK", 8)
    a = spill.SpillArray(30, (2,))
    ref = np.arange(60.0).reshape(30, 2)
    for k in range(30):
        a[k] = ref[k]
    for start, stop in ((0, 30), (3, 21), (8, 16), (5, 5)):
        parts = list(spill.row_blocks(a, start, stop))
        assert all(len(p) <= 8 for p in parts)
        np.testing.assert_array_equal(np.concatenate(parts) if parts else ref[:0],
                                      ref[start:stop])


def test_joint_and_head_scores_blockwise_equal_the_whole_columns(monkeypatch):
    """The mimic stage's joints/head section, reduced block by block over spilled columns,
    against numpy on the whole arrays and scipy's rotation angles."""
    from types import SimpleNamespace

    from scipy.spatial.transform import Rotation

    from humimic.metrics.mimicry_report import _joints_and_head

    monkeypatch.setattr(spill, "BLOCK", 16)
    n, rng = 70, np.random.default_rng(3)
    lim = np.array([[-1.0, 1.0], [-0.5, 2.0], [0.0, 0.3]])
    q = rng.uniform(-1.2, 2.1, (n, 3))
    ctrl = rng.standard_normal((n, 3))
    p = rng.normal(0.0, 0.01, (n, 3))
    R = Rotation.from_rotvec(rng.normal(0.0, 0.05, (n, 3))).as_matrix()
    cols = {"q_robot": q, "ctrl": ctrl, "p_head": p, "R_head": R.reshape(n, 9)}
    rec = SimpleNamespace(n=n)
    for name, v in cols.items():
        setattr(rec, name, spill.SpillArray(n + 5, v.shape[1:]))
        for k in range(n):
            getattr(rec, name)[k] = v[k]
    stage = SimpleNamespace(rec=rec, scene=SimpleNamespace(robot_range=lim))
    joints, dp, dr = _joints_and_head(stage)
    excess = np.maximum(lim[:, 0] - q, q - lim[:, 1])
    assert joints == {"limit_violations": int(np.sum(excess > 0)),
                      "max_limit_excess_rad": float(excess.max()), "finite": True}
    assert dp == np.linalg.norm(p - p[0], axis=1).max()
    angles = (Rotation.from_matrix(R[0]).inv() * Rotation.from_matrix(R)).magnitude()
    np.testing.assert_allclose(dr, angles.max(), atol=1e-9)
