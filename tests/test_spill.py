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
    rows = [(float(k), rng.standard_normal((2, 3)), ["", "lost"][k % 2], k % 3 == 0)
            for k in range(11)]
    log = spill.SpillRows()
    for r in rows:
        log.append(r)
    assert len(log) == 11 and [r[0] for r in log] == [r[0] for r in rows]
    for got, want in zip(log.columns(), zip(*rows, strict=True), strict=True):
        np.testing.assert_array_equal(got, np.array(want))
