"""The mimic stage's scores and plots read a long run's record a block of rows at a time:
the blocks and strided rows of ``site_series`` are the whole series' rows, and the budget
summed over blocks is the whole arrays' (``maths.stats.rmse`` on the whole error terms)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from humimic import spill
from humimic.maths.stats import rmse
from humimic.metrics.mimicry import TERMS, error_terms, mse_shares
from humimic.metrics.mimicry_report import (
    SERIES_KEYS,
    series_blocks,
    site_budget,
    site_series,
)

RATE, N_REC, K0 = 840.0, 203, 17  # record rows; site 1 starts at row K0


@pytest.fixture
def stage(monkeypatch):
    monkeypatch.setattr(spill, "BLOCK", 16)  # many spilled blocks in a short record
    rng = np.random.default_rng(5)
    n_gt = 2 * N_REC + 10
    p_gt = {"hand": rng.normal(size=(n_gt, 3)), "chest": rng.normal(size=(n_gt, 3))}
    gt = SimpleNamespace(t=np.arange(n_gt) / RATE, p_base=lambda name: p_gt[name])
    rec = SimpleNamespace(n=N_REC, dt=2 / RATE)
    cols = {"t": (np.arange(N_REC) * 2 / RATE, ()),
            "t_est": (None, (2,)), "t_ready": (None, (2,)), "scale": (None, (2,)),
            "active": (None, (2,))}
    for name in ("p_cmd", "p_cmd_raw", "p_cmd_alt", "p_ik", "p_robot", "p_est"):
        cols[name] = (rng.normal(size=(N_REC, 2, 3)), (2, 3))
    cols["t_est"] = (cols["t"][0][:, None] - rng.uniform(0, 0.3, (N_REC, 2)), (2,))
    cols["t_ready"] = (cols["t_est"][0] + rng.uniform(0, 0.03, (N_REC, 2)), (2,))
    cols["scale"] = (rng.uniform(0.8, 1.0, (N_REC, 2)), (2,))
    active = np.zeros((N_REC, 2), bool)
    active[K0:, 1] = True
    cols["active"] = (active, (2,))
    cols["p_est"][0][K0 + 40:K0 + 45, 1] = np.nan  # a lost estimate: NaN rows in two terms
    for name, (v, tail) in cols.items():
        a = spill.SpillArray(N_REC + 7, tail, v.dtype)
        for k in range(N_REC):
            a[k] = v[k]
        setattr(rec, name, a)
    world = SimpleNamespace(gt=gt, scenario=SimpleNamespace(timing=SimpleNamespace(
        physics_rate=RATE)))
    ch = SimpleNamespace(target="hand", ref="chest", M=np.diag([1.0, -1.0, 1.0]),
                         p0_robot=np.array([0.3, -0.2, 1.0]), t0=0.05)
    return SimpleNamespace(rec=rec, world=world), ch


def test_blocks_and_strided_rows_are_the_whole_series(stage):
    stage, ch = stage
    k0, whole = site_series(stage, 1, ch)
    assert k0 == K0 and len(whole["t"]) == N_REC - 1 - K0
    blocks = list(series_blocks(stage, 1, ch, SERIES_KEYS, block=23))
    assert len(blocks) == -(-len(whole["t"]) // 23)
    for key in SERIES_KEYS:
        np.testing.assert_array_equal(np.concatenate([b[key] for b in blocks]), whole[key])
        np.testing.assert_array_equal(site_series(stage, 1, ch, (key,), slice(None, None, 7))
                                      [1][key], whole[key][::7])


def test_budget_summed_over_blocks_is_the_whole_arrays(stage):
    stage, ch = stage
    _, s = site_series(stage, 1, ch)
    terms = error_terms(s["true_now"], s["true_photon"], s["true_ready"], s["true_stale"],
                        s["est"], s["cmd_raw"], s["cmd"], s["ik"], s["robot"])
    assert np.any(rmse(terms["stale_hold"]) > 0.0)  # some rows held past MAX_AGE
    rms, shares, top = site_budget(stage, 1, ch)
    for name in (*TERMS, "total"):
        assert rms[name] == pytest.approx(rmse(terms[name]), rel=1e-12)
    whole = mse_shares(terms)
    for name in TERMS:
        assert shares[name] == pytest.approx(whole[name], rel=1e-9, abs=1e-12)
    assert top == np.max(np.linalg.norm(terms["total"], axis=1))
