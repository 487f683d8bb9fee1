"""``split_arms`` (:mod:`humimic.perception.trackers.kpf.split`): the five groups' DOFs and
likelihood columns from the names, the per-group log-weights against sums written out by hand,
the resampling's ancestors per group, and a short tracking run."""

from __future__ import annotations

import numpy as np
import pytest
from _kpf_synth import INTRINSICS, camera, painted_person, static_pose

from humimic import bodymodel as bm
from humimic.perception.trackers.kpf.split import (
    split_groups,
    split_log_lik,
    split_part_columns,
    split_resample_indices,
)
from humimic.perception.trackers.kpf.tracker import kpf_body


def test_groups_are_the_torso_and_each_arms_shoulder_and_elbow_by_name():
    groups = split_groups(bm.DOF_NAMES)
    names = [[bm.DOF_NAMES[i] for i in g] for g in groups]
    assert names == [list(bm.TORSO_DOFS), ["R_SFE", "R_SAA", "R_HR"], ["R_EB"],
                     ["L_SFE", "L_SAA", "L_HR"], ["L_EB"]]
    # a partition of all 14 DOFs
    assert sorted(np.concatenate(groups).tolist()) == list(range(len(bm.DOF_NAMES)))


def test_shoulder_weighs_its_whole_arm_and_elbow_only_the_parts_below_the_upper_arm():
    parts = kpf_body().part_names
    cols = [[parts[i] for i in c] for c in split_part_columns(parts)]
    assert cols == [["r_upper_arm", "r_forearm", "r_hand"], ["r_forearm", "r_hand"],
                    ["l_upper_arm", "l_forearm", "l_hand"], ["l_forearm", "l_hand"]]


def test_group_log_weights_are_the_sums_written_out():
    rng = np.random.default_rng(3)
    parts = kpf_body().part_names
    terms = rng.normal(size=(7, len(parts)))
    torso, arm = rng.normal(size=7), rng.normal(size=(7, 2))
    got = split_log_lik(terms, split_part_columns(parts), torso, arm)
    t = {p: terms[:, i] for i, p in enumerate(parts)}
    want = np.column_stack([
        sum(t.values()) + torso + arm[:, 0] + arm[:, 1],
        t["r_upper_arm"] + t["r_forearm"] + t["r_hand"] + arm[:, 0],
        t["r_forearm"] + t["r_hand"] + arm[:, 0],
        t["l_upper_arm"] + t["l_forearm"] + t["l_hand"] + arm[:, 1],
        t["l_forearm"] + t["l_hand"] + arm[:, 1]])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def _one_hot_weights(n: int, winners: list[int]) -> np.ndarray:
    W = np.zeros((n, len(winners)))
    W[winners, range(len(winners))] = 1.0
    return W


@pytest.mark.parametrize("mode, want", [("groups", [2, 5, 7, 0, 9]), ("arm", [2, 5, 5, 0, 0])])
def test_each_group_takes_its_own_ancestor_and_arm_mode_shares_the_shoulders(mode, want):
    """All weight of group k on one particle: every row's group k is that particle's values,
    the other groups' from their own winners (``arm``: the elbow follows its shoulder)."""
    from humimic.estimation.particles.kernel import partitioned_take

    n = 10
    idx = split_resample_indices(_one_hot_weights(n, [2, 5, 7, 0, 9]), mode,
                                 np.random.default_rng(0))
    assert idx.shape == (n, 5) and np.all(idx == np.array(want))
    x = np.arange(n * 14, dtype=float).reshape(n, 14)
    groups = split_groups(bm.DOF_NAMES)
    out = partitioned_take(x, idx, groups)
    for g, k in zip(groups, want, strict=True):
        np.testing.assert_array_equal(out[:, g], np.broadcast_to(x[k, g], (n, len(g))))


def test_resampling_follows_the_weights_per_group():
    """Systematic resampling: each group's ancestor counts are within one of N w."""
    rng = np.random.default_rng(5)
    W = rng.random((200, 5))
    W /= W.sum(0)
    idx = split_resample_indices(W, "groups", np.random.default_rng(1))
    for k in range(5):
        counts = np.bincount(idx[:, k], minlength=200)
        assert np.all(np.abs(counts - 200 * W[:, k]) <= 1.0 + 1e-9)


@pytest.mark.parametrize("mode", ["groups", "arm"])
def test_short_run_with_split_arms_is_finite_and_tracks(mode):
    """A painted person standing still: 3 frames at 150 particles stay finite, the five
    groups' weights normalised, the right wrist within 6 cm (as test_kpf_hands')."""
    from humimic.perception.blobs.config import DEFAULT_COLOR_MODEL
    from humimic.perception.cues.color_models import ColorLUT, load_color_model
    from humimic.perception.trackers.kpf.config import KpfConfig
    from humimic.perception.trackers.kpf.frame_cues import FrameCues
    from humimic.perception.trackers.kpf.tracker import KpfTracker

    body = kpf_body()
    T, q0 = camera(), static_pose()
    img = painted_person(body, q0, T)
    lut = ColorLUT(load_color_model(DEFAULT_COLOR_MODEL), 6)
    cfg = KpfConfig(n_particles=150, iterations=2, partitioned=True, split_arms=True,
                    split_resample=mode, torso_prior_m=0.03, kde_stride=4)
    tr = KpfTracker(body, INTRINSICS, cfg, np.random.default_rng(0))
    tr.start(q0, FrameCues(img, lut), T)
    wrist = body.forward(q0[None]).joint("r_wrist")[0]
    for _ in range(3):
        res = tr.step(FrameCues(img, lut), T)
        assert np.all(np.isfinite(res.particles)) and tr.W.shape == (150, 5)
        np.testing.assert_allclose(tr.W.sum(0), 1.0, atol=1e-9)
        err = np.linalg.norm(body.forward(res.mode[None]).joint("r_wrist")[0] - wrist)
        assert err < 0.06, err
