"""The hot paths' stack helper against numpy's own ``np.stack``."""

from __future__ import annotations

import numpy as np
import pytest

from humimic.maths.arrays import stack


@pytest.mark.parametrize("axis", [0, 1, 2, 3, -1, -2, -4])
def test_stack_equals_numpy_stack_on_every_axis_and_dtype(axis):
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(3, 4, 5)), rng.normal(size=(3, 4, 5))
    c = rng.normal(size=(3, 4, 5)).astype(np.float32)
    for arrays in ([a, b], [a, b, c], [c, c], [a[:, ::2], b[:, 1::2]]):
        want = np.stack(arrays, axis)
        got = stack(arrays, axis)
        assert got.dtype == want.dtype and np.array_equal(got, want)


def test_stack_rejects_unequal_shapes_and_bad_axes():
    with pytest.raises(ValueError):
        stack([np.zeros(3), np.zeros(4)])
    with pytest.raises(ValueError):
        stack([np.zeros((2, 3)), np.zeros(3)])      # no silent broadcasting
    with pytest.raises(np.exceptions.AxisError):
        stack([np.zeros(3), np.zeros(3)], axis=2)
