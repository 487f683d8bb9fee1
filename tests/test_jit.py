"""The project's numba options: compiled functions keep numpy's division semantics."""

import numpy as np

from humimic.maths.jit import njit


@njit
def _ratio(a, b):
    out = np.empty_like(a)
    for i in range(a.size):
        out[i] = a[i] / b[i]
    return out


def test_njit_divides_like_numpy():
    a = np.array([1.0, -1.0, 0.0, 2.0])
    b = np.array([0.0, 0.0, 0.0, 4.0])
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = a / b
    np.testing.assert_array_equal(_ratio(a, b), expected)
