"""``weights_columns`` (the groups' weights in one pass) against ``weights`` per column (bit for
bit: the kernel particle filter's results must not change) and against scipy's ``softmax``;
columns with no information (all ``-inf``, NaN) uniform as ``weights`` makes them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import softmax

from humimic.estimation.particles.kernel import partitioned_resample_indices
from humimic.estimation.particles.resampling import resample_indices
from humimic.estimation.particles.weights import weights, weights_columns


@pytest.mark.parametrize("n", [1, 5, 37, 150, 1000])
def test_weights_columns_equal_weights_per_column_and_softmax(n):
    rng = np.random.default_rng(n)
    lw = rng.normal(-500.0, 30.0, (n, 5))
    lw[rng.random((n, 5)) < 0.1] = -np.inf
    lw[:, 3] = -np.inf                                  # no information: uniform
    lw[0, 4] = np.nan                                   # NaN: uniform
    got = weights_columns(lw)
    assert got.flags.c_contiguous and got.shape == (n, 5)
    for k in range(5):
        assert np.array_equal(got[:, k], weights(lw[:, k]))
    for k in range(3):
        if np.isfinite(lw[:, k]).any():
            np.testing.assert_allclose(got[:, k], softmax(lw[:, k]), rtol=1e-12, atol=0)
    np.testing.assert_allclose(got[:, 3:], 1.0 / n, rtol=1e-15)


def test_partitioned_resample_indices_draw_as_per_group_resampling():
    """The same uniforms in the same order as ``resample_indices`` per group."""
    rng = np.random.default_rng(1)
    W = rng.random((200, 3)) ** 4
    W /= W.sum(axis=0)
    got = partitioned_resample_indices(W, [None] * 3, np.random.default_rng(9))
    r = np.random.default_rng(9)
    want = np.stack([resample_indices(np.log(np.maximum(W[:, k], 1e-300)), r)
                     for k in range(3)], axis=1)
    assert np.array_equal(got, want)
